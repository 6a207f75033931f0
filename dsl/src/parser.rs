//! Text → syntax tree: runs the pre-pass, the pest grammar, and builds [`crate::ast`] nodes.
//!
//! Recursion is bounded everywhere: bracket nesting is limited by the pre-pass, operator
//! chains are folded with explicit stacks, `else if` chains are a repetition in the grammar,
//! and the height of every built tree is checked against [`MAX_NESTING`].

use pest::error::{ErrorVariant, InputLocation};
use pest::iterators::Pair;
use pest::Parser as _;

use crate::ast::*;
use crate::error::ParseError;
use crate::lexer::{prelex, Lexed};
use crate::{MAX_INPUT_LEN, MAX_NESTING, MAX_OPERATORS};

#[derive(pest_derive::Parser)]
#[grammar = "grammar.pest"]
struct MbdParser;

/// At most this many errors are reported for one file.
const MAX_ERRORS: usize = 10;
/// Recovery after a syntax error re-parses the file; above this size only the first error is
/// reported, so that a broken huge file costs one parse.
const RECOVERY_LIMIT: usize = 1 << 20;

fn check_size(src: &str) -> Result<(), Vec<ParseError>> {
    if src.len() > MAX_INPUT_LEN {
        return Err(vec![ParseError::new(
            Span::new(0, 0),
            format!(
                "the input is too large ({} bytes; at most {} MiB are accepted)",
                src.len(),
                MAX_INPUT_LEN >> 20
            ),
        )
        .with_help("split the scene into several files with `import`")]);
    }
    Ok(())
}

/// Up to this bracket depth the parser runs on the caller's stack (real scenes nest about
/// 3 to 6 levels; 16 levels need about half a megabyte in an unoptimized build).
const INLINE_DEPTH: usize = 16;
/// Stack reserved per level of bracket nesting when parsing on a dedicated thread (generous
/// enough for unoptimized builds, where a level costs some tens of kilobytes).
const STACK_PER_LEVEL: usize = 128 * 1024;

/// Runs `f` on the current thread if the text nests shallowly, else on a scoped thread with
/// a stack sized for the nesting, so that deep (but accepted) nesting cannot overflow the
/// caller's stack, whatever its size.
fn with_stack<T: Send>(depth: usize, f: impl FnOnce() -> T + Send) -> Result<T, ParseError> {
    if depth <= INLINE_DEPTH {
        return Ok(f());
    }
    let size = (depth + 16) * STACK_PER_LEVEL;
    std::thread::scope(|scope| {
        let handle = std::thread::Builder::new()
            .name("mbdc-dsl-parse".into())
            .stack_size(size)
            .spawn_scoped(scope, f)
            .map_err(|e| {
                ParseError::new(
                    Span::new(0, 0),
                    format!("could not start a thread to parse deeply nested text: {e}"),
                )
            })?;
        handle
            .join()
            .map_err(|_| ParseError::new(Span::new(0, 0), "internal error: the parser panicked"))
    })
}

/// Parses a whole file.
pub(crate) fn parse_file(src: &str) -> Result<File, Vec<ParseError>> {
    check_size(src)?;
    let lexed = prelex(src, false).map_err(|e| vec![e])?;
    let depth = lexed.max_depth;
    with_stack(depth, move || parse_lexed(src, lexed)).map_err(|e| vec![e])?
}

fn parse_lexed(src: &str, lexed: Lexed) -> Result<File, Vec<ParseError>> {
    let Lexed {
        masked,
        comments,
        pairs,
        ..
    } = lexed;
    let mut text = masked;
    let mut errors: Vec<ParseError> = Vec::new();
    loop {
        match MbdParser::parse(Rule::file, &text) {
            Ok(mut parsed) => {
                let Some(file_pair) = parsed.next() else {
                    errors.push(ParseError::new(
                        Span::new(0, 0),
                        "internal error: empty parse",
                    ));
                    break;
                };
                let mut builder = Builder {
                    text: &text,
                    errors: Vec::new(),
                    operators: 0,
                    expr_level: 0,
                };
                let mut file = builder.file(file_pair);
                errors.extend(builder.errors);
                if errors.is_empty() {
                    attach_comments(&mut file.items, &mut file.trailing_comments, &comments, src);
                    mark_blank_lines(&mut file.items, &mut file.trailing_comments, src);
                    return Ok(file);
                }
                break;
            }
            Err(e) => {
                let err = explain_pest_error(e, &text, false);
                let pos = err.span.start;
                if errors
                    .iter()
                    .any(|x| x.span == err.span && x.message == err.message)
                {
                    break;
                }
                errors.push(err);
                if errors.len() >= MAX_ERRORS || text.len() > RECOVERY_LIMIT {
                    break;
                }
                if !blank_region(&mut text, pos, &pairs) {
                    break;
                }
            }
        }
    }
    errors.sort_by_key(|e| (e.span.start, e.span.end));
    errors.truncate(MAX_ERRORS);
    Err(errors)
}

/// Parses a single expression (newlines are whitespace).
pub(crate) fn parse_expression(src: &str) -> Result<Expr, Vec<ParseError>> {
    check_size(src)?;
    let lexed = prelex(src, true).map_err(|e| vec![e])?;
    let depth = lexed.max_depth;
    with_stack(depth, move || parse_lexed_expr(lexed.masked)).map_err(|e| vec![e])?
}

fn parse_lexed_expr(text: String) -> Result<Expr, Vec<ParseError>> {
    let mut parsed = MbdParser::parse(Rule::expr_input, &text)
        .map_err(|e| vec![explain_pest_error(e, &text, true)])?;
    let mut builder = Builder {
        text: &text,
        errors: Vec::new(),
        operators: 0,
        expr_level: 0,
    };
    let result = parsed
        .next()
        .and_then(|p| p.into_inner().find(|p| p.as_rule() == Rule::expr))
        .ok_or_else(|| ParseError::new(Span::new(0, 0), "internal error: no expression"))
        .and_then(|p| builder.expr(p));
    match result {
        Ok((expr, _)) if builder.errors.is_empty() => Ok(expr),
        Ok(_) => Err(builder.errors),
        Err(e) => {
            let mut errors = builder.errors;
            errors.push(e);
            errors.sort_by_key(|e| (e.span.start, e.span.end));
            Err(errors)
        }
    }
}

// ------------------------------------------------------------------------------------------
// Error recovery

/// Replaces the item around `pos` by spaces (keeping newlines and the brackets of enclosing
/// blocks), so that the next parse can find the following error. Returns false if nothing
/// could be removed.
fn blank_region(text: &mut String, pos: usize, pairs: &[(usize, usize)]) -> bool {
    let bytes = text.as_bytes();
    let n = bytes.len();
    let pos = pos.min(n);
    let line_end = |from: usize| {
        bytes[from.min(n)..]
            .iter()
            .position(|&b| b == b'\n')
            .map_or(n, |p| p + from)
    };
    let mut s = bytes[..pos]
        .iter()
        .rposition(|&b| b == b'\n')
        .map_or(0, |p| p + 1);
    let mut e = line_end(pos);
    for _ in 0..64 {
        let mut changed = false;
        for &(o, c) in pairs {
            if o < s && c >= s && c < e {
                // A closing bracket of an enclosing group: keep it.
                if c < pos {
                    s = c + 1;
                } else {
                    e = c;
                }
                changed = true;
            } else if o >= s && o < e && c >= e {
                // A group opened in the region: remove it whole.
                e = line_end(c + 1);
                changed = true;
            }
        }
        if !changed || s >= e {
            break;
        }
    }
    // A block that starts on the next line belongs to the broken item.
    let mut k = e;
    while k < n && is_blank(bytes[k]) {
        k += 1;
    }
    if k < n && bytes[k] == b'{' && e < n {
        if let Some(&(_, c)) = pairs.iter().find(|(o, _)| *o == k) {
            e = line_end(c + 1);
        }
    }
    if s >= e
        || !text.as_bytes()[s..e]
            .iter()
            .any(|b| !b.is_ascii_whitespace() && *b != 0x0C)
    {
        return false;
    }
    let replacement: String = text[s..e]
        .chars()
        .flat_map(|c| std::iter::repeat_n(if c == '\n' { '\n' } else { ' ' }, c.len_utf8()))
        .collect();
    text.replace_range(s..e, &replacement);
    true
}

// ------------------------------------------------------------------------------------------
// Building the tree

struct Builder<'t> {
    text: &'t str,
    errors: Vec<ParseError>,
    /// Binary operators in the outermost expression being built (with its nested ones).
    operators: usize,
    /// How many `expr` calls are under way (0: none, 1: the outermost).
    expr_level: usize,
}

type Res<T> = Result<T, ParseError>;

fn span_of(pair: &Pair<'_, Rule>) -> Span {
    let s = pair.as_span();
    Span::new(s.start(), s.end())
}

/// A name; reserved words are refused here (the grammar accepts them as names, see
/// grammar.pest).
fn ident_of(pair: &Pair<'_, Rule>) -> Res<Ident> {
    let name = pair.as_str();
    let span = span_of(pair);
    if RESERVED.contains(&name) {
        return Err(reserved_error(name, span));
    }
    Ok(Ident {
        name: name.to_string(),
        span,
    })
}

fn reserved_error(word: &str, span: Span) -> ParseError {
    if word == "else" {
        return ParseError::new(span, "`else` without `if`")
            .with_help("`else` must follow the closing `}` of an `if` block");
    }
    ParseError::new(
        span,
        format!("`{word}` is a reserved word and cannot be used as a name"),
    )
    .with_help(format!(
        "choose another name; the reserved words are {}",
        RESERVED.map(|r| format!("`{r}`")).join(" ")
    ))
}

fn too_deep(span: Span) -> ParseError {
    ParseError::new(
        span,
        format!("nested too deeply (more than {MAX_NESTING} levels)"),
    )
    .with_help("split the expression or the block, e.g. with `const` values")
}

fn check_height(h: u32, span: Span) -> Res<u32> {
    if h as usize > MAX_NESTING {
        Err(too_deep(span))
    } else {
        Ok(h)
    }
}

/// Binding power of binary operators (higher binds tighter).
fn bin_prec(op: BinOp) -> u8 {
    match op {
        BinOp::At => 1,
        BinOp::Or => 2,
        BinOp::And => 3,
        BinOp::Eq | BinOp::Ne | BinOp::Lt | BinOp::Le | BinOp::Gt | BinOp::Ge => 5,
        BinOp::Add | BinOp::Sub => 6,
        BinOp::Mul | BinOp::Div | BinOp::Rem => 7,
        BinOp::Pow => 9,
    }
}

/// Binding power of unary operators: `not` between `and` and comparisons, `-` between
/// products and `^`.
fn un_prec(op: UnOp) -> u8 {
    match op {
        UnOp::Not => 4,
        UnOp::Neg => 8,
    }
}

fn is_cmp(op: BinOp) -> bool {
    matches!(
        op,
        BinOp::Eq | BinOp::Ne | BinOp::Lt | BinOp::Le | BinOp::Gt | BinOp::Ge
    )
}

fn bin_op(text: &str) -> Option<BinOp> {
    Some(match text {
        "+" => BinOp::Add,
        "-" => BinOp::Sub,
        "*" => BinOp::Mul,
        "/" => BinOp::Div,
        "%" => BinOp::Rem,
        "^" => BinOp::Pow,
        "==" => BinOp::Eq,
        "!=" => BinOp::Ne,
        "<" => BinOp::Lt,
        "<=" => BinOp::Le,
        ">" => BinOp::Gt,
        ">=" => BinOp::Ge,
        "and" => BinOp::And,
        "or" => BinOp::Or,
        "@" => BinOp::At,
        _ => return None,
    })
}

enum StackOp {
    Prefix(UnOp, usize),
    Infix(BinOp),
}

/// The children of a pair, without punctuation.
struct Parts<'i> {
    span: Span,
    inner: pest::iterators::Pairs<'i, Rule>,
}

impl<'i> Parts<'i> {
    fn try_next(&mut self) -> Option<Pair<'i, Rule>> {
        self.inner.by_ref().find(|p| !is_punct(p.as_rule()))
    }

    fn next(&mut self, what: &str) -> Res<Pair<'i, Rule>> {
        self.try_next()
            .ok_or_else(|| ParseError::new(self.span, format!("internal error: missing {what}")))
    }
}

struct Segment {
    prefixes: Vec<(UnOp, Span)>,
    operand: (Expr, u32),
}

impl<'t> Builder<'t> {
    fn file(&mut self, pair: Pair<'_, Rule>) -> File {
        let items = self.items(pair.into_inner());
        File {
            items,
            trailing_comments: Vec::new(),
        }
    }

    fn items<'i>(&mut self, pairs: impl Iterator<Item = Pair<'i, Rule>>) -> Vec<Item> {
        let mut items = Vec::new();
        for p in pairs {
            if p.as_rule() == Rule::item {
                match self.item(p) {
                    Ok((item, _)) => items.push(item),
                    Err(e) => self.errors.push(e),
                }
            }
        }
        items
    }

    fn block(&mut self, pair: Pair<'_, Rule>) -> Res<(Block, u32)> {
        let span = span_of(&pair);
        let mut height = 0;
        let mut items = Vec::new();
        for p in pair.into_inner() {
            if p.as_rule() == Rule::item {
                match self.item(p) {
                    Ok((item, h)) => {
                        height = height.max(h);
                        items.push(item);
                    }
                    Err(e) => self.errors.push(e),
                }
            }
        }
        let h = check_height(height + 1, span)?;
        Ok((
            Block {
                items,
                trailing_comments: Vec::new(),
                span,
            },
            h,
        ))
    }

    /// One item. Each kind has its own method so that (in unoptimized builds) the frame
    /// of this recursive path stays small.
    fn item(&mut self, pair: Pair<'_, Rule>) -> Res<(Item, u32)> {
        // pest's implicit whitespace before an optional repetition that matches nothing
        // stays in the pair (e.g. after the last value of a property); items end at their
        // last token.
        let mut span = span_of(&pair);
        let bytes = self.text.as_bytes();
        while span.end > span.start && is_blank(bytes[span.end - 1]) {
            span.end -= 1;
        }
        let Some(inner) = pair.into_inner().next() else {
            return Err(ParseError::new(span, "internal error: empty item"));
        };
        let parts = Parts {
            span,
            inner: inner.clone().into_inner(),
        };
        let (kind, height) = match inner.as_rule() {
            Rule::import_item => self.import_item(parts)?,
            Rule::param_item => self.value_item(parts, true)?,
            Rule::const_item => self.value_item(parts, false)?,
            Rule::component_item => self.component_item(parts)?,
            Rule::for_item => self.for_item(parts)?,
            Rule::if_item => self.if_item(parts)?,
            Rule::decl => self.decl_item(parts)?,
            Rule::prop => self.prop_item(parts)?,
            _ => return Err(ParseError::new(span, "internal error: unknown item")),
        };
        Ok((
            Item {
                comments: Vec::new(),
                trailing_comment: None,
                kind,
                span,
                blank_before: false,
            },
            height,
        ))
    }

    #[inline(never)]
    fn import_item(&mut self, mut parts: Parts<'_>) -> Res<(ItemKind, u32)> {
        let _kw = parts.next("keyword")?;
        let path = self.string(parts.next("path")?)?;
        Ok((ItemKind::Import { path }, 1))
    }

    #[inline(never)]
    fn value_item(&mut self, mut parts: Parts<'_>, param: bool) -> Res<(ItemKind, u32)> {
        let _kw = parts.next("keyword")?;
        let name = ident_of(&parts.next("name")?)?;
        let (value, h) = self.expr(parts.next("value")?)?;
        Ok(if param {
            (ItemKind::Param { name, value }, h)
        } else {
            (ItemKind::Const { name, value }, h)
        })
    }

    #[inline(never)]
    fn component_item(&mut self, mut parts: Parts<'_>) -> Res<(ItemKind, u32)> {
        let span = parts.span;
        let _kw = parts.next("keyword")?;
        let name = ident_of(&parts.next("name")?)?;
        let mut params = Vec::new();
        let mut height = 0;
        let mut body = None;
        while let Some(p) = parts.try_next() {
            match p.as_rule() {
                Rule::cparam => {
                    let mut it = p.into_inner().filter(|p| !is_punct(p.as_rule()));
                    let Some(pname) = it.next() else { continue };
                    let default = match it.next() {
                        Some(e) => {
                            let (e, h) = self.expr(e)?;
                            height = height.max(h);
                            Some(e)
                        }
                        None => None,
                    };
                    params.push(ComponentParam {
                        name: ident_of(&pname)?,
                        default,
                    });
                }
                Rule::block => {
                    let (b, h) = self.block(p)?;
                    height = height.max(h);
                    body = Some(b);
                }
                _ => {}
            }
        }
        let body =
            body.ok_or_else(|| ParseError::new(span, "internal error: component without body"))?;
        Ok((ItemKind::Component { name, params, body }, height))
    }

    #[inline(never)]
    fn for_item(&mut self, mut parts: Parts<'_>) -> Res<(ItemKind, u32)> {
        let _kw = parts.next("keyword")?;
        let var = ident_of(&parts.next("variable")?)?;
        let _in = parts.next("in")?;
        let (start, h1) = self.expr(parts.next("start")?)?;
        let (end, h2) = self.expr(parts.next("end")?)?;
        let (body, h3) = self.block(parts.next("body")?)?;
        Ok((
            ItemKind::For {
                var,
                start,
                end,
                body,
            },
            h1.max(h2).max(h3),
        ))
    }

    #[inline(never)]
    fn if_item(&mut self, mut parts: Parts<'_>) -> Res<(ItemKind, u32)> {
        let span = parts.span;
        let _kw = parts.next("keyword")?;
        let (cond, h1) = self.expr(parts.next("condition")?)?;
        let (then, h2) = self.block(parts.next("block")?)?;
        // The chain of `else if` branches, then an optional final `else` block; nested
        // from the end without recursion.
        let mut branches = Vec::new();
        let mut otherwise: Option<(Block, u32)> = None;
        while let Some(p) = parts.try_next() {
            match p.as_rule() {
                Rule::else_if => {
                    let mut it = Parts {
                        span,
                        inner: p.into_inner(),
                    };
                    let _else = it.next("else")?;
                    let kw_if = it.next("if")?;
                    let start = kw_if.as_span().start();
                    let (c, hc) = self.expr(it.next("condition")?)?;
                    let (b, hb) = self.block(it.next("block")?)?;
                    branches.push((start, c, b, hc.max(hb)));
                }
                Rule::else_block => {
                    if let Some(b) = p.into_inner().find(|p| p.as_rule() == Rule::block) {
                        otherwise = Some(self.block(b)?);
                    }
                }
                _ => {}
            }
        }
        for (start, c, b, h) in branches.into_iter().rev() {
            let item_span = Span::new(start, span.end);
            let (other, ho) = match otherwise.take() {
                Some((blk, ho)) => (Some(blk), ho),
                None => (None, 0),
            };
            let item = Item {
                comments: Vec::new(),
                trailing_comment: None,
                kind: ItemKind::If {
                    cond: c,
                    then: b,
                    otherwise: other,
                },
                span: item_span,
                blank_before: false,
            };
            let hb = check_height(h.max(ho) + 1, item_span)?;
            otherwise = Some((
                Block {
                    items: vec![item],
                    trailing_comments: Vec::new(),
                    span: item_span,
                },
                hb,
            ));
        }
        let (other, h3) = match otherwise {
            Some((b, h)) => (Some(b), h),
            None => (None, 0),
        };
        Ok((
            ItemKind::If {
                cond,
                then,
                otherwise: other,
            },
            h1.max(h2).max(h3),
        ))
    }

    #[inline(never)]
    fn decl_item(&mut self, mut parts: Parts<'_>) -> Res<(ItemKind, u32)> {
        let span = parts.span;
        let keyword = ident_of(&parts.next("keyword")?)?;
        let mut name = None;
        let mut value = None;
        let mut body = None;
        let mut height = 0;
        while let Some(p) = parts.try_next() {
            match p.as_rule() {
                Rule::decl_name => {
                    let (n, h) = self.name(p)?;
                    height = height.max(h);
                    name = Some(n);
                }
                Rule::expr => {
                    let (e, h) = self.expr(p)?;
                    height = height.max(h);
                    value = Some(e);
                }
                Rule::block => {
                    let (b, h) = self.block(p)?;
                    height = height.max(h);
                    body = Some(b);
                }
                _ => {}
            }
        }
        if name.is_none() && body.is_none() {
            let k = &keyword.name;
            return Err(ParseError::new(
                span,
                format!("`{k} = ...` has no name: a declaration without a name needs a block"),
            )
            .with_help(format!(
                "for a property write `{k} VALUE` without `=`; for a declaration write `{k} NAME = VALUE`"
            )));
        }
        Ok((
            ItemKind::Decl {
                keyword,
                name,
                value,
                body,
            },
            height,
        ))
    }

    #[inline(never)]
    fn prop_item(&mut self, mut parts: Parts<'_>) -> Res<(ItemKind, u32)> {
        let key = ident_of(&parts.next("key")?)?;
        let mut values = Vec::new();
        let mut block = None;
        let mut height = 0;
        while let Some(p) = parts.try_next() {
            match p.as_rule() {
                Rule::expr => {
                    let (e, h) = self.expr(p)?;
                    height = height.max(h);
                    values.push(e);
                }
                Rule::block => {
                    let (b, h) = self.block(p)?;
                    height = height.max(h);
                    block = Some(b);
                }
                _ => {}
            }
        }
        Ok((ItemKind::Prop { key, values, block }, height))
    }

    fn name(&mut self, pair: Pair<'_, Rule>) -> Res<(Name, u32)> {
        let span = span_of(&pair);
        let mut it = pair.into_inner();
        let base = ident_of(
            &it.next()
                .ok_or_else(|| ParseError::new(span, "internal error: name"))?,
        )?;
        let mut indices = Vec::new();
        let mut height = 0;
        for p in it {
            if p.as_rule() == Rule::index {
                if let Some(e) = p.into_inner().find(|p| p.as_rule() == Rule::expr) {
                    let (e, h) = self.expr(e)?;
                    height = height.max(h);
                    indices.push(e);
                }
            }
        }
        Ok((
            Name {
                base,
                indices,
                span,
            },
            height,
        ))
    }

    fn string(&mut self, pair: Pair<'_, Rule>) -> Res<StrLit> {
        let span = span_of(&pair);
        let raw = pair.into_inner().next().map_or("", |p| p.as_str());
        let mut value = String::with_capacity(raw.len());
        let mut chars = raw.char_indices();
        while let Some((i, c)) = chars.next() {
            if c != '\\' {
                value.push(c);
                continue;
            }
            match chars.next() {
                Some((_, '"')) => value.push('"'),
                Some((_, '\\')) => value.push('\\'),
                Some((_, 'n')) => value.push('\n'),
                Some((_, other)) => {
                    let at = span.start + 1 + i;
                    return Err(ParseError::new(
                        Span::new(at, at + 1 + other.len_utf8()),
                        format!("unknown escape `\\{other}` in a string"),
                    )
                    .with_help("the escapes are `\\\"`, `\\\\` and `\\n`"));
                }
                None => value.push('\\'),
            }
        }
        Ok(StrLit { value, span })
    }

    /// An expression: validates the flat operator sequence and folds it by precedence with
    /// explicit stacks (shunting-yard), so that neither long chains nor long prefix runs
    /// recurse.
    /// An expression with the height consumers recurse to: a chain of binary operators
    /// written without brackets (`a + b + c`, a left-deep tree) counts once, since consumers
    /// walk its left spine in a loop; only `^` (right-associative) counts per operator. The
    /// length of chains is bounded separately, by [`MAX_OPERATORS`] per expression.
    fn expr(&mut self, pair: Pair<'_, Rule>) -> Res<(Expr, u32)> {
        if self.expr_level == 0 {
            self.operators = 0;
        }
        self.expr_level += 1;
        let r = self.expr_inner(pair);
        self.expr_level -= 1;
        r
    }

    fn expr_inner(&mut self, pair: Pair<'_, Rule>) -> Res<(Expr, u32)> {
        let mut segments: Vec<Segment> = Vec::new();
        let mut ops: Vec<(BinOp, Span)> = Vec::new();
        let mut prefixes: Vec<(UnOp, Span)> = Vec::new();
        for p in pair.into_inner() {
            match p.as_rule() {
                Rule::prefix_op => {
                    let op = if p.as_str() == "-" {
                        UnOp::Neg
                    } else {
                        UnOp::Not
                    };
                    prefixes.push((op, span_of(&p)));
                }
                Rule::operand => {
                    let operand = self.operand(p)?;
                    segments.push(Segment {
                        prefixes: std::mem::take(&mut prefixes),
                        operand,
                    });
                }
                Rule::infix_op => {
                    let span = span_of(&p);
                    let op = bin_op(p.as_str())
                        .ok_or_else(|| ParseError::new(span, "internal error: unknown operator"))?;
                    ops.push((op, span));
                }
                _ => {}
            }
        }
        if segments.len() != ops.len() + 1 {
            return Err(ParseError::new(
                Span::new(0, 0),
                "internal error: malformed expression",
            ));
        }

        // The restrictions of the layered grammar.
        let mut cmp_seen: Option<Span> = None;
        let mut at_seen: Option<Span> = None;
        for (i, seg) in segments.iter().enumerate() {
            let before = if i == 0 { None } else { Some(ops[i - 1]) };
            if let Some((op, op_span)) = before {
                if is_cmp(op) {
                    if cmp_seen.is_some() {
                        return Err(ParseError::new(op_span, "comparisons cannot be chained")
                            .with_help(
                            "combine them with `and`, e.g. `a < b and b < c`, or use parentheses",
                        ));
                    }
                    cmp_seen = Some(op_span);
                } else if matches!(op, BinOp::And | BinOp::Or | BinOp::At) {
                    cmp_seen = None;
                }
                if op == BinOp::At {
                    if at_seen.is_some() {
                        return Err(ParseError::new(op_span, "only one `@` is allowed in an expression")
                            .with_help("`@` attaches a point to a body: `body @ (x, y, z)`; use parentheses to nest"));
                    }
                    at_seen = Some(op_span);
                }
            }
            let mut neg_seen = false;
            for &(op, pspan) in &seg.prefixes {
                match op {
                    UnOp::Neg => neg_seen = true,
                    UnOp::Not => {
                        if neg_seen {
                            return Err(ParseError::new(pspan, "`not` cannot follow a unary `-`")
                                .with_help("write `-(not x)` if that is really meant"));
                        }
                        if let Some((bop, _)) = before {
                            if !matches!(bop, BinOp::And | BinOp::Or | BinOp::At) {
                                return Err(ParseError::new(
                                    pspan,
                                    format!(
                                        "`not` must be put in parentheses after `{}`",
                                        bop.as_str()
                                    ),
                                )
                                .with_help(format!("write e.g. `a {} (not b)`", bop.as_str())));
                            }
                        }
                    }
                }
            }
        }

        if let Some((_, at)) = ops.get(MAX_OPERATORS.saturating_sub(self.operators)) {
            return Err(ParseError::new(
                *at,
                format!("more than {MAX_OPERATORS} operators in one expression"),
            )
            .with_help("split it into parts with `const` declarations and add those"));
        }
        self.operators += ops.len();
        // Shunting-yard.
        let mut out: Vec<(Expr, u32)> = Vec::with_capacity(segments.len());
        let mut stack: Vec<StackOp> = Vec::new();
        let mut ops_iter = ops.into_iter();
        for (i, seg) in segments.into_iter().enumerate() {
            if i > 0 {
                let Some((op, _)) = ops_iter.next() else {
                    break;
                };
                let p = bin_prec(op);
                while let Some(top) = stack.last() {
                    let pop = match *top {
                        StackOp::Prefix(u, _) => un_prec(u) > p,
                        StackOp::Infix(t) => {
                            let tp = bin_prec(t);
                            tp > p || (tp == p && op != BinOp::Pow)
                        }
                    };
                    if !pop {
                        break;
                    }
                    if let Some(top) = stack.pop() {
                        reduce(&mut out, top)?;
                    }
                }
                stack.push(StackOp::Infix(op));
            }
            for (op, pspan) in seg.prefixes {
                stack.push(StackOp::Prefix(op, pspan.start));
            }
            out.push(seg.operand);
        }
        while let Some(top) = stack.pop() {
            reduce(&mut out, top)?;
        }
        match (out.pop(), out.is_empty()) {
            (Some(e), true) => Ok(e),
            _ => Err(ParseError::new(
                Span::new(0, 0),
                "internal error: expression fold",
            )),
        }
    }

    fn operand(&mut self, pair: Pair<'_, Rule>) -> Res<(Expr, u32)> {
        let span = span_of(&pair);
        let mut it = pair.into_inner();
        let first = it
            .next()
            .ok_or_else(|| ParseError::new(span, "internal error: operand"))?;
        let first_rule = first.as_rule();
        let (mut expr, mut height) = match first_rule {
            Rule::number => {
                let text = first.as_str().to_string();
                let value: f64 = text.parse().map_err(|_| {
                    ParseError::new(span_of(&first), format!("invalid number `{text}`"))
                })?;
                if !value.is_finite() {
                    return Err(ParseError::new(
                        span_of(&first),
                        format!("the number `{text}` is too large"),
                    ));
                }
                let unit = match it.next() {
                    Some(u) => Some(self.unit(u)?),
                    None => None,
                };
                return Ok((
                    Expr {
                        kind: ExprKind::Number { value, text, unit },
                        span,
                    },
                    1,
                ));
            }
            Rule::string => {
                let s = self.string(first)?;
                return Ok((
                    Expr {
                        kind: ExprKind::Str(s),
                        span,
                    },
                    1,
                ));
            }
            Rule::kw_true => {
                return Ok((
                    Expr {
                        kind: ExprKind::Bool(true),
                        span,
                    },
                    1,
                ))
            }
            Rule::kw_false => {
                return Ok((
                    Expr {
                        kind: ExprKind::Bool(false),
                        span,
                    },
                    1,
                ))
            }
            Rule::ident => (
                Expr {
                    kind: ExprKind::Ident(ident_of(&first)?),
                    span: span_of(&first),
                },
                1,
            ),
            Rule::call => self.call(first)?,
            Rule::group => self.group(first)?,
            Rule::list => {
                let lspan = span_of(&first);
                let (items, h) = self.expr_list(first)?;
                (
                    Expr {
                        kind: ExprKind::List(items),
                        span: lspan,
                    },
                    check_height(h + 1, lspan)?,
                )
            }
            _ => return Err(ParseError::new(span, "internal error: unknown operand")),
        };
        let mut postfixes = 0;
        for p in it {
            match p.as_rule() {
                Rule::postfix => {
                    postfixes += 1;
                    let Some(op) = p.into_inner().next() else {
                        continue;
                    };
                    let end = op.as_span().end();
                    let nspan = Span::new(expr.span.start, end);
                    match op.as_rule() {
                        Rule::index => {
                            let Some(e) = op.into_inner().find(|p| p.as_rule() == Rule::expr)
                            else {
                                continue;
                            };
                            let (index, h) = self.expr(e)?;
                            height = check_height(height.max(h) + 1, nspan)?;
                            expr = Expr {
                                kind: ExprKind::Index {
                                    base: Box::new(expr),
                                    index: Box::new(index),
                                },
                                span: nspan,
                            };
                        }
                        Rule::member => {
                            let Some(m) = op.into_inner().next() else {
                                continue;
                            };
                            height = check_height(height + 1, nspan)?;
                            expr = Expr {
                                kind: ExprKind::Member {
                                    base: Box::new(expr),
                                    member: ident_of(&m)?,
                                },
                                span: nspan,
                            };
                        }
                        _ => {}
                    }
                }
                Rule::unit_suffix => {
                    let unit = self.unit(p)?;
                    let after_paren =
                        postfixes == 0 && matches!(first_rule, Rule::call | Rule::group);
                    if !after_paren {
                        let base = &self.text[expr.span.start..expr.span.end];
                        return Err(ParseError::new(
                            unit.span,
                            format!(
                                "a unit must follow a number or a closing parenthesis directly, e.g. `2 {}` or `(L / 2) {}`",
                                unit.text, unit.text
                            ),
                        )
                        .with_help(format!(
                            "to give `{base}` a unit, write `({base}) {}` or `{base} * 1 {}`; if these are two values, separate them with `,`",
                            unit.text, unit.text
                        )));
                    }
                    let nspan = Span::new(expr.span.start, unit.span.end);
                    height = check_height(height + 1, nspan)?;
                    expr = Expr {
                        kind: ExprKind::WithUnit {
                            expr: Box::new(expr),
                            unit,
                        },
                        span: nspan,
                    };
                }
                _ => {}
            }
        }
        Ok((expr, height))
    }

    fn call(&mut self, pair: Pair<'_, Rule>) -> Res<(Expr, u32)> {
        let span = span_of(&pair);
        let mut it = pair.into_inner();
        let func = ident_of(
            &it.next()
                .ok_or_else(|| ParseError::new(span, "internal error: call"))?,
        )?;
        let mut args = Vec::new();
        let mut height = 0;
        if let Some(a) = it.next() {
            for arg in a.into_inner().filter(|p| p.as_rule() == Rule::arg) {
                let mut name = None;
                let mut value = None;
                for p in arg.into_inner() {
                    match p.as_rule() {
                        Rule::arg_name => {
                            if let Some(p) = p.into_inner().find(|p| p.as_rule() == Rule::ident) {
                                name = Some(ident_of(&p)?);
                            }
                        }
                        Rule::expr => {
                            let (e, h) = self.expr(p)?;
                            height = height.max(h);
                            value = Some(e);
                        }
                        _ => {}
                    }
                }
                if let Some(value) = value {
                    args.push(Arg { name, value });
                }
            }
        }
        let h = check_height(height + 1, span)?;
        Ok((
            Expr {
                kind: ExprKind::Call { func, args },
                span,
            },
            h,
        ))
    }

    fn group(&mut self, pair: Pair<'_, Rule>) -> Res<(Expr, u32)> {
        let span = span_of(&pair);
        let trailing_comma = pair
            .clone()
            .into_inner()
            .filter(|p| p.as_rule() != Rule::rparen)
            .last()
            .is_some_and(|p| p.as_rule() == Rule::comma);
        let (mut items, h) = self.expr_list(pair)?;
        let h = check_height(h + 1, span)?;
        match items.len() {
            0 => Err(ParseError::new(span, "empty parentheses")
                .with_help("write a value inside, e.g. `(0, 0, 0)`")),
            1 if trailing_comma => {
                Err(ParseError::new(span, "a tuple needs at least two elements")
                    .with_help("remove the trailing comma: `(x)` is just `x` in parentheses"))
            }
            1 => {
                let inner = items
                    .pop()
                    .map(Box::new)
                    .ok_or_else(|| ParseError::new(span, "internal error"))?;
                Ok((
                    Expr {
                        kind: ExprKind::Paren(inner),
                        span,
                    },
                    h,
                ))
            }
            _ => Ok((
                Expr {
                    kind: ExprKind::Tuple(items),
                    span,
                },
                h,
            )),
        }
    }

    fn expr_list(&mut self, pair: Pair<'_, Rule>) -> Res<(Vec<Expr>, u32)> {
        let mut items = Vec::new();
        let mut height = 0;
        for p in pair.into_inner() {
            if p.as_rule() == Rule::expr {
                let (e, h) = self.expr(p)?;
                height = height.max(h);
                items.push(e);
            }
        }
        Ok((items, height))
    }

    fn unit(&mut self, pair: Pair<'_, Rule>) -> Res<Unit> {
        // Accept both `unit_suffix` (spaces + unit) and `unit`.
        let pair = if pair.as_rule() == Rule::unit_suffix {
            let span = span_of(&pair);
            pair.into_inner()
                .next()
                .ok_or_else(|| ParseError::new(span, "internal error: unit"))?
        } else {
            pair
        };
        let span = span_of(&pair);
        let text = pair.as_str().to_string();
        let mut factors = Vec::new();
        let mut sign = 1i32;
        for p in pair.into_inner() {
            match p.as_rule() {
                Rule::unit_one => sign = -1,
                Rule::unit_op => sign = if p.as_str() == "/" { -1 } else { 1 },
                Rule::unit_atom => {
                    let mut it = p.into_inner();
                    let Some(name) = it.next() else { continue };
                    let exp = match it.next() {
                        Some(e) => e
                            .as_str()
                            .parse::<i32>()
                            .ok()
                            .and_then(|x| x.checked_mul(sign))
                            .ok_or_else(|| {
                                ParseError::new(
                                    span_of(&e),
                                    format!("the unit exponent `{}` is too large", e.as_str()),
                                )
                            })?,
                        None => sign,
                    };
                    let uname = name.as_str();
                    if uname != "in" && RESERVED.contains(&uname) {
                        return Err(ParseError::new(
                            span_of(&name),
                            format!("`{uname}` is a reserved word and cannot be a unit"),
                        ));
                    }
                    factors.push((
                        Ident {
                            name: uname.to_string(),
                            span: span_of(&name),
                        },
                        exp,
                    ));
                }
                _ => {}
            }
        }
        Ok(Unit {
            factors,
            text,
            span,
        })
    }
}

fn is_punct(rule: Rule) -> bool {
    matches!(
        rule,
        Rule::eq
            | Rule::lbrace
            | Rule::rbrace
            | Rule::lparen
            | Rule::rparen
            | Rule::lbracket
            | Rule::rbracket
            | Rule::comma
            | Rule::colon
            | Rule::dotdot
            | Rule::sep
    )
}

fn reduce(out: &mut Vec<(Expr, u32)>, op: StackOp) -> Res<()> {
    let internal = || ParseError::new(Span::new(0, 0), "internal error: operand stack");
    match op {
        StackOp::Prefix(u, start) => {
            let (e, h) = out.pop().ok_or_else(internal)?;
            let span = Span::new(start, e.span.end);
            let h = check_height(h + 1, span)?;
            out.push((
                Expr {
                    kind: ExprKind::Unary {
                        op: u,
                        expr: Box::new(e),
                    },
                    span,
                },
                h,
            ));
        }
        StackOp::Infix(b) => {
            let (rhs, hr) = out.pop().ok_or_else(internal)?;
            let (lhs, hl) = out.pop().ok_or_else(internal)?;
            let span = lhs.span.to(rhs.span);
            // the left operand of a left-associative operator is walked in a loop by
            // consumers (see `expr`): only the right one adds a level
            let h = if b == BinOp::Pow {
                hl.max(hr) + 1
            } else {
                hl.max(hr + 1)
            };
            let h = check_height(h, span)?;
            out.push((
                Expr {
                    kind: ExprKind::Binary {
                        op: b,
                        lhs: Box::new(lhs),
                        rhs: Box::new(rhs),
                    },
                    span,
                },
                h,
            ));
        }
    }
    Ok(())
}

// ------------------------------------------------------------------------------------------
// Comments

/// Attaches comments (sorted, all inside the region of `items`) to items: a comment on the
/// same line after an item is its trailing comment, comments before an item lead it,
/// comments inside an item (but outside its blocks) are added to its leading comments, and
/// comments after the last item trail the block or file.
fn attach_comments(
    items: &mut [Item],
    trailing: &mut Vec<Comment>,
    comments: &[Comment],
    src: &str,
) {
    let mut inner: Vec<Vec<Comment>> = vec![Vec::new(); items.len()];
    let mut idx = 0;
    let mut after_prev_trailing_allowed = true;
    for c in comments {
        while idx < items.len() && items[idx].span.end <= c.span.start {
            idx += 1;
            after_prev_trailing_allowed = true;
        }
        if idx < items.len() && items[idx].span.start <= c.span.start {
            inner[idx].push(c.clone());
            continue;
        }
        if idx > 0 && after_prev_trailing_allowed && items[idx - 1].trailing_comment.is_none() {
            let prev_end = items[idx - 1].span.end;
            if !src.as_bytes()[prev_end..c.span.start].contains(&b'\n') {
                items[idx - 1].trailing_comment = Some(c.clone());
                continue;
            }
        }
        after_prev_trailing_allowed = false;
        if idx < items.len() {
            items[idx].comments.push(c.clone());
        } else {
            trailing.push(c.clone());
        }
    }
    for (item, inner) in items.iter_mut().zip(inner) {
        if inner.is_empty() {
            continue;
        }
        let mut rest = inner;
        for block in item_blocks(&mut item.kind) {
            let (inside, outside): (Vec<Comment>, Vec<Comment>) = rest
                .into_iter()
                .partition(|c| block.span.start < c.span.start && c.span.end <= block.span.end);
            rest = outside;
            if !inside.is_empty() {
                attach_comments(&mut block.items, &mut block.trailing_comments, &inside, src);
            }
        }
        item.comments.extend(rest);
    }
}

/// Whether a blank line (two line ends with only blanks between) comes right before `start`;
/// not at the start of the file.
fn blank_line_before(src: &[u8], start: usize) -> bool {
    let mut newlines = 0;
    for &b in src[..start.min(src.len())].iter().rev() {
        match b {
            b'\n' => newlines += 1,
            b' ' | b'\t' | b'\r' => {}
            _ => return newlines >= 2,
        }
    }
    false
}

/// Sets `blank_before` of every item and comment from the source, so that
/// [`format`](crate::format()) keeps the author's blank lines (runs collapsed to one).
fn mark_blank_lines(items: &mut [Item], trailing: &mut [Comment], src: &str) {
    let bytes = src.as_bytes();
    for item in items.iter_mut() {
        item.blank_before = blank_line_before(bytes, item.span.start);
        for c in &mut item.comments {
            c.blank_before = blank_line_before(bytes, c.span.start);
        }
        for block in item_blocks(&mut item.kind) {
            mark_blank_lines(&mut block.items, &mut block.trailing_comments, src);
        }
    }
    for c in trailing {
        c.blank_before = blank_line_before(bytes, c.span.start);
    }
}

fn item_blocks(kind: &mut ItemKind) -> Vec<&mut Block> {
    match kind {
        ItemKind::Component { body, .. } | ItemKind::For { body, .. } => vec![body],
        ItemKind::Decl { body, .. } => body.iter_mut().collect(),
        ItemKind::Prop { block, .. } => block.iter_mut().collect(),
        ItemKind::If {
            then, otherwise, ..
        } => {
            let mut v = vec![then];
            v.extend(otherwise.iter_mut());
            v
        }
        _ => Vec::new(),
    }
}

// ------------------------------------------------------------------------------------------
// Explaining pest errors in plain words

#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Want {
    Expr,
    Name,
    Item,
    Str,
    Eq,
    LBrace,
    LParen,
    Comma,
    Colon,
    RParen,
    RBracket,
    RBrace,
    In,
    DotDot,
    Operator,
    End,
}

impl Want {
    fn words(self) -> &'static str {
        match self {
            Want::Expr => "an expression",
            Want::Name => "a name",
            Want::Item => "a declaration or a property",
            Want::End => "a new line or `;`",
            Want::Eq => "`=`",
            Want::LBrace => "`{`",
            Want::LParen => "`(`",
            Want::RParen => "`)`",
            Want::RBracket => "`]`",
            Want::RBrace => "`}`",
            Want::Comma => "`,`",
            Want::Colon => "`:`",
            Want::In => "`in`",
            Want::DotDot => "`..`",
            Want::Str => "a string in quotes",
            Want::Operator => "an operator",
        }
    }
}

fn want_of(rule: Rule) -> Option<Want> {
    Some(match rule {
        Rule::expr
        | Rule::prefix_op
        | Rule::neg
        | Rule::kw_not
        | Rule::operand
        | Rule::number
        | Rule::kw_true
        | Rule::kw_false
        | Rule::call
        | Rule::group
        | Rule::list
        | Rule::arg => Want::Expr,
        Rule::string => Want::Str,
        Rule::ident | Rule::decl_name | Rule::cparam => Want::Name,
        Rule::item
        | Rule::import_item
        | Rule::param_item
        | Rule::const_item
        | Rule::component_item
        | Rule::for_item
        | Rule::if_item
        | Rule::decl
        | Rule::prop
        | Rule::kw_import
        | Rule::kw_param
        | Rule::kw_const
        | Rule::kw_component
        | Rule::kw_for
        | Rule::kw_if => Want::Item,
        Rule::sep | Rule::EOI => Want::End,
        Rule::eq => Want::Eq,
        Rule::lbrace | Rule::block => Want::LBrace,
        Rule::lparen | Rule::args => Want::LParen,
        Rule::rparen => Want::RParen,
        Rule::rbracket => Want::RBracket,
        Rule::rbrace => Want::RBrace,
        Rule::comma => Want::Comma,
        Rule::colon => Want::Colon,
        Rule::kw_in => Want::In,
        Rule::dotdot => Want::DotDot,
        Rule::infix_op => Want::Operator,
        _ => return None,
    })
}

const RESERVED: [&str; 13] = [
    "import",
    "param",
    "const",
    "component",
    "for",
    "in",
    "if",
    "else",
    "and",
    "or",
    "not",
    "true",
    "false",
];

/// The token at `pos`: a description and its span.
fn found_at(text: &str, pos: usize) -> (String, Span, TokKind) {
    let bytes = text.as_bytes();
    let Some(&b) = bytes.get(pos) else {
        return (
            "the end of the file".into(),
            Span::new(text.len(), text.len()),
            TokKind::End,
        );
    };
    match b {
        b'\n' => (
            "the end of the line".into(),
            Span::new(pos, pos),
            TokKind::End,
        ),
        b'a'..=b'z' | b'A'..=b'Z' | b'_' => {
            let end = word_end(bytes, pos);
            (
                format!("`{}`", &text[pos..end]),
                Span::new(pos, end),
                TokKind::Word,
            )
        }
        b'0'..=b'9' => {
            let end = word_end(bytes, pos);
            (
                format!("`{}`", &text[pos..end]),
                Span::new(pos, end),
                TokKind::Number,
            )
        }
        b'"' => {
            let end = text[pos + 1..]
                .find('"')
                .map_or(text.len(), |p| pos + p + 2);
            ("a string".into(), Span::new(pos, end), TokKind::Other)
        }
        _ => {
            let start = crate::offsets::floor_char_boundary(text, pos);
            let c = text[start..].chars().next().unwrap_or(' ');
            let two = text
                .get(start..start + 2)
                .filter(|t| matches!(*t, "==" | "!=" | "<=" | ">=" | ".."));
            if let Some(t) = two {
                return (
                    format!("`{t}`"),
                    Span::new(start, start + 2),
                    TokKind::Other,
                );
            }
            let desc = if !c.is_control() && !c.is_whitespace() {
                format!("`{c}`")
            } else {
                format!("the character U+{:04X}", c as u32)
            };
            (desc, Span::new(start, start + c.len_utf8()), TokKind::Other)
        }
    }
}

#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum TokKind {
    End,
    Word,
    Number,
    Other,
}

fn word_end(bytes: &[u8], mut i: usize) -> usize {
    while i < bytes.len() && (bytes[i].is_ascii_alphanumeric() || bytes[i] == b'_') {
        i += 1;
    }
    i
}

fn is_blank(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | b'\r' | b'\n' | 0x0C)
}

/// The token before `pos` (skipping whitespace), as written, with its start offset.
fn prev_token(text: &str, pos: usize) -> Option<(String, usize, TokKind)> {
    let bytes = text.as_bytes();
    let mut end = pos.min(bytes.len());
    while end > 0 && is_blank(bytes[end - 1]) {
        end -= 1;
    }
    if end == 0 {
        return None;
    }
    let last = bytes[end - 1];
    if last.is_ascii_alphanumeric() || last == b'_' {
        let mut start = end;
        while start > 0
            && (bytes[start - 1].is_ascii_alphanumeric()
                || bytes[start - 1] == b'_'
                || bytes[start - 1] == b'.')
        {
            start -= 1;
        }
        // Keep numbers like `2.5` whole, but stop at a member access `a.b` or a range `..`.
        let word = &text[start..end];
        let word = match word.rfind('.') {
            Some(d) if !word[..d].bytes().all(|b| b.is_ascii_digit()) || word[..d].is_empty() => {
                &word[d + 1..]
            }
            _ => word,
        };
        let start = end - word.len();
        let kind = if word.as_bytes()[0].is_ascii_digit() {
            TokKind::Number
        } else {
            TokKind::Word
        };
        return Some((word.to_string(), start, kind));
    }
    if last == b'"' {
        return Some(("the string".into(), end - 1, TokKind::Other));
    }
    let start = crate::offsets::floor_char_boundary(text, end - 1);
    if start >= 1 {
        if let Some(t) = text
            .get(start - 1..end)
            .filter(|t| matches!(*t, "==" | "!=" | "<=" | ">=" | ".."))
        {
            return Some((t.to_string(), start - 1, TokKind::Other));
        }
    }
    Some((text[start..end].to_string(), start, TokKind::Other))
}

fn list_words(wants: &[Want]) -> String {
    let mut words: Vec<&str> = Vec::new();
    for w in wants {
        if *w == Want::End {
            words.extend(["a new line", "`;`"]);
        } else {
            words.push(w.words());
        }
    }
    match words.len() {
        0 => "something else".into(),
        1 => words[0].into(),
        _ => format!(
            "{} or {}",
            words[..words.len() - 1].join(", "),
            words[words.len() - 1]
        ),
    }
}

/// The first word of the item that contains `pos` (for context-specific help).
fn item_keyword(text: &str, pos: usize) -> Option<&str> {
    let bytes = text.as_bytes();
    let mut i = pos.min(bytes.len());
    while i > 0 && !matches!(bytes[i - 1], b'\n' | b';' | b'{' | b'}') {
        i -= 1;
    }
    while i < bytes.len() && is_blank(bytes[i]) {
        i += 1;
    }
    let end = word_end(bytes, i);
    (end > i).then(|| &text[i..end])
}

fn explain_pest_error(err: pest::error::Error<Rule>, text: &str, expr_mode: bool) -> ParseError {
    let pos = match err.location {
        InputLocation::Pos(p) => p,
        InputLocation::Span((s, _)) => s,
    };
    let (positives, negatives) = match err.variant {
        ErrorVariant::ParsingError {
            positives,
            negatives,
        } => (positives, negatives),
        ErrorVariant::CustomError { message } => {
            let span = Span::new(pos, pos);
            return if message.contains("limit") {
                too_deep(span)
            } else {
                ParseError::new(span, message)
            };
        }
    };
    let _ = negatives;
    let mut wants: Vec<Want> = positives.iter().filter_map(|r| want_of(*r)).collect();
    wants.sort();
    wants.dedup();
    if wants.contains(&Want::Expr) {
        wants.retain(|w| *w != Want::Name);
    }
    if wants.contains(&Want::End) {
        wants.retain(|w| *w != Want::RBrace);
    }
    let (found, found_span, found_kind) = found_at(text, pos);
    let prev = prev_token(text, pos);
    let after = prev
        .as_ref()
        .map(|(t, _, _)| format!(" after `{t}`"))
        .unwrap_or_default();
    let found_word = (found_kind == TokKind::Word).then(|| &text[found_span.start..found_span.end]);

    // A reserved word where a name or an expression was expected.
    if let Some(w) = found_word {
        if w == "else"
            || RESERVED.contains(&w)
                && !matches!(w, "not" | "true" | "false" | "and" | "or")
                && wants.iter().any(|x| matches!(x, Want::Name | Want::Expr))
        {
            return reserved_error(w, found_span);
        }
    }

    let mut structural: Vec<Want> = wants
        .iter()
        .copied()
        .filter(|w| *w != Want::Operator)
        .collect();
    if structural.len() > 1 {
        // `(` after a name that could be called is rarely what was meant.
        structural.retain(|w| *w != Want::LParen);
    }
    let bytes = text.as_bytes();
    let c = bytes.get(found_span.start).copied();
    let stray = found_kind == TokKind::Other
        && c.is_some_and(|c| c != b'"' && !b"(){}[],;:.=<>!+-*/%^@".contains(&c));
    let mut message = if stray {
        format!("unexpected character {found}")
    } else if expr_mode && structural.contains(&Want::End) {
        format!("expected the end of the input{after}, found {found}")
    } else if structural.contains(&Want::End) {
        let mut others: Vec<Want> = structural
            .iter()
            .copied()
            .filter(|w| !matches!(w, Want::End | Want::Expr | Want::Name))
            .collect();
        others.push(Want::End);
        format!("expected {}{after}, found {found}", list_words(&others))
    } else if structural.contains(&Want::Expr) {
        format!("expected an expression{after}, found {found}")
    } else if structural.is_empty() {
        format!("unexpected {found}{after}")
    } else {
        format!("expected {}{after}, found {found}", list_words(&structural))
    };
    let mut help: Option<String> = None;

    // At the start of a line where an item may begin.
    let line_start = bytes[..found_span.start.min(bytes.len())]
        .iter()
        .rev()
        .find(|b| !matches!(b, b' ' | b'\t' | b'\r' | 0x0C))
        .is_none_or(|b| matches!(b, b'\n' | b';' | b'{'));
    if line_start && structural.contains(&Want::Item) && found_kind != TokKind::Word && !stray {
        let c = c.unwrap_or(b' ');
        let mut e = ParseError::new(
            found_span,
            format!("expected a declaration or a property, found {found}"),
        );
        if b"+-*/%^@=<>,".contains(&c) {
            e = e.with_help(
                "a line that starts with an operator does not continue the previous one: end the previous line with the operator instead",
            );
        } else if c == b'{' {
            e = e.with_help(
                "put the `{` on the same line as the declaration it belongs to, e.g. `body rod {`",
            );
        } else {
            e = e.with_help("an item starts with a name, e.g. `mass 1 kg` or `body rod { ... }`");
        }
        return e;
    }

    let space_before = found_span.start > 0 && matches!(bytes[found_span.start - 1], b' ' | b'\t');
    let prev_kind = prev.as_ref().map(|p| p.2);
    let prev_text = prev.as_ref().map(|p| p.0.as_str()).unwrap_or("");

    if stray {
        help = Some("names are made of ASCII letters, digits and `_`; operators are `+ - * / % ^ == != < <= > >= @ and or not`".into());
    } else if structural.contains(&Want::End) || structural.is_empty() {
        // The item could have ended here: something extra follows on the same line.
        let glued_unit = (!space_before && matches!(c, Some(b'(' | b'[' | b'.')))
            .then(|| unit_before(text, found_span.start))
            .flatten()
            .filter(|u| u.contains(['*', '/']));
        if let Some(unit) = glued_unit {
            help = Some(format!(
                "`{unit}` was read as one unit because it has no spaces; a space ends a unit, so write e.g. `1 N * sin(x)` rather than `1 N*sin(x)`"
            ));
        } else if c == Some(b'(') && !space_before && matches!(prev_kind, Some(TokKind::Word)) {
            message = "only a plain name can be called".to_string();
            help = Some("call functions by their name, e.g. `norm(v)`; `a.b(...)` and `a[i](...)` are not calls".into());
        } else if matches!(c, Some(b'(' | b'['))
            && space_before
            && matches!(prev_kind, Some(TokKind::Word))
        {
            let what = if c == Some(b'(') { "call" } else { "index" };
            let open = c.map_or('(', |c| c as char);
            help = Some(format!(
                "to {what} `{prev_text}`, write the `{open}` right after it without a space: `{prev_text}{open}...`"
            ));
        } else if let (Some(_), Some(unit)) = (found_word, unit_before(text, found_span.start)) {
            help = Some(format!(
                "a unit is one word without spaces: write `{unit}*{}` (use `*` and `/` between unit names, `^` for powers)",
                unit_word_at(text, found_span.start)
            ));
        } else if c == Some(b'{')
            && bytes[..found_span.start]
                .iter()
                .rev()
                .find(|b| !is_blank(**b) || **b == b'\n')
                == Some(&b'\n')
        {
            message = "unexpected `{` at the start of a line".to_string();
            help = Some(
                "put the `{` on the same line as the declaration it belongs to, e.g. `body rod {`"
                    .into(),
            );
        } else if c == Some(b'.') && prev_kind == Some(TokKind::Number) {
            help =
                Some("write numbers with a digit after the point, e.g. `5.0`, or none: `5`".into());
        } else if c == Some(b'{') {
            help = Some("a block can only follow a declaration `KEYWORD NAME` or `KEYWORD NAME = VALUE`, a property-free `KEYWORD`, or two or more values of a property (`glue a, m.b { ... }`); check the words before `{`".into());
        } else if c == Some(b'=') {
            help =
                Some("a declaration is `KEYWORD NAME = VALUE`; `=` cannot follow a value".into());
        } else if c == Some(b':') {
            help = Some(
                "`name: value` arguments are only allowed inside a call, e.g. `rod(length: 1 m)`"
                    .into(),
            );
        } else if matches!(found_kind, TokKind::Word | TokKind::Number | TokKind::Other) {
            help = Some("write each item on its own line (or separate items with `;`) and separate values with `,`".into());
        }
    } else if structural.contains(&Want::Expr) {
        if found_kind == TokKind::End && matches!(prev_text, "=" | "(" | "[" | ":") {
            help = Some("a line break ends an item; write the value on the same line".into());
        } else if c == Some(b'{') && prev_text == "=" {
            help =
                Some("a declaration with a block has no `=` before it: `body rod { ... }`".into());
        } else if c == Some(b'.')
            && bytes
                .get(found_span.start + 1)
                .is_some_and(u8::is_ascii_digit)
        {
            help = Some("write numbers with a digit before the point, e.g. `0.5`".into());
        }
    } else if structural == [Want::Eq] {
        if let Some(k @ ("param" | "const")) = item_keyword(text, pos) {
            help = Some(format!(
                "a `{k}` needs a value: `{k} NAME = VALUE`, e.g. `{k} L = 1 m`"
            ));
        }
    } else if structural == [Want::Str] {
        help = Some("write the path in quotes, e.g. `import \"parts/link.mbd\"`".into());
    } else if structural.contains(&Want::In) {
        help = Some("a loop is written `for i in 0..N { ... }`".into());
    } else if structural.contains(&Want::DotDot) {
        help = Some("a loop range is written `START..END` (END excluded), e.g. `0..N`".into());
    } else if structural.contains(&Want::LBrace)
        && item_keyword(text, pos).is_some_and(|k| matches!(k, "if" | "for" | "component"))
    {
        help = Some("the block must start on the same line, e.g. `if i == 0 { ... }`".into());
    }
    let mut e = ParseError::new(found_span, message);
    if let Some(h) = help {
        e = e.with_help(h);
    }
    e
}

/// The length of the number literal at the start of `s`, as the grammar reads it
/// (`12`, `2.5`, `1e-6`; the `e` of `2e` is not part of the number).
fn number_len(s: &str) -> usize {
    let b = s.as_bytes();
    let digits = |mut i: usize| {
        while i < b.len() && b[i].is_ascii_digit() {
            i += 1;
        }
        i
    };
    let mut i = digits(0);
    if b.get(i) == Some(&b'.') && b.get(i + 1).is_some_and(u8::is_ascii_digit) {
        i = digits(i + 1);
    }
    if matches!(b.get(i), Some(b'e' | b'E')) {
        let j = if matches!(b.get(i + 1), Some(b'+' | b'-')) {
            i + 2
        } else {
            i + 1
        };
        if b.get(j).is_some_and(u8::is_ascii_digit) {
            i = digits(j);
        }
    }
    i
}

/// The unit-like word at `pos`: letters, digits, `_`, `*`, `/`, `^`, `-` up to a space.
fn unit_word_at(text: &str, pos: usize) -> &str {
    let bytes = text.as_bytes();
    let mut e = pos;
    while e < bytes.len()
        && (bytes[e].is_ascii_alphanumeric()
            || matches!(bytes[e], b'_' | b'*' | b'/' | b'^' | b'-'))
    {
        e += 1;
    }
    &text[pos..e]
}

/// The unit written directly before `pos` (after a number or `)`, separated by spaces), if
/// any: in `2 kg m` the unit before `m` is `kg`.
fn unit_before(text: &str, pos: usize) -> Option<&str> {
    let bytes = text.as_bytes();
    let mut e = pos.min(bytes.len());
    while e > 0 && matches!(bytes[e - 1], b' ' | b'\t') {
        e -= 1;
    }
    let mut s = e;
    while s > 0
        && (bytes[s - 1].is_ascii_alphanumeric()
            || matches!(bytes[s - 1], b'_' | b'*' | b'/' | b'^' | b'-' | b'.'))
    {
        s -= 1;
    }
    let run = &text[s..e];
    let first = *run.as_bytes().first()?;
    if first.is_ascii_digit() && !run.starts_with("1/") {
        // A number glued to its unit (`2kg`): the unit starts where the number ends.
        let unit = &run[number_len(run)..];
        return unit
            .starts_with(|c: char| c.is_ascii_alphabetic() || c == '_')
            .then_some(unit);
    }
    let mut j = s;
    while j > 0 && matches!(bytes[j - 1], b' ' | b'\t') {
        j -= 1;
    }
    let before = *bytes.get(j.checked_sub(1)?)?;
    (before == b')' || before.is_ascii_digit()).then_some(run)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn blanked(src: &str, pos: usize) -> Option<String> {
        let lexed = prelex(src, false).unwrap_or_else(|e| panic!("{e:?}"));
        let mut text = lexed.masked;
        blank_region(&mut text, pos, &lexed.pairs).then_some(text)
    }

    #[test]
    fn recovery_blanks_the_broken_item_only() {
        let src = "model m {\n  a 1 2\n  b 3\n}\n";
        assert_eq!(
            blanked(src, 16).as_deref(),
            Some("model m {\n       \n  b 3\n}\n")
        );
        // A block opened on the broken line goes with it, the enclosing `}` stays.
        let src = "m {\n  body x y {\n    mass 1\n  }\n  c 1 }\n";
        assert_eq!(
            blanked(src, 13).as_deref(),
            Some("m {\n            \n          \n   \n  c 1 }\n")
        );
        let src = "m {\n  c 1 2 }\n";
        assert_eq!(blanked(src, 10).as_deref(), Some("m {\n        }\n"));
        // A block on the next line belongs to the broken item.
        let src = "if x\n{ a 1 }\nb 2\n";
        assert_eq!(blanked(src, 4).as_deref(), Some("    \n       \nb 2\n"));
        // Nothing left to remove: no progress.
        assert_eq!(blanked("a 1\n\n", 4), None);
    }

    #[test]
    fn unit_before_finds_the_unit_of_a_number() {
        assert_eq!(unit_before("mass 2 kg m", 10), Some("kg"));
        assert_eq!(unit_before("mass 2kg m", 9), Some("kg"));
        assert_eq!(unit_before("x (1) m/s kg", 10), Some("m/s"));
        assert_eq!(unit_before("x a kg", 5), None);
        assert_eq!(unit_before("x 1e5 y", 6), None);
        assert_eq!(unit_before("x 2e y", 5), Some("e"));
        assert_eq!(unit_before("x 1.5e-3kg y", 11), Some("kg"));
        assert_eq!(
            (
                number_len("12ab"),
                number_len("2.5e-3"),
                number_len("2e"),
                number_len("1.x")
            ),
            (2, 6, 1, 1)
        );
    }

    #[test]
    fn precedences_are_ordered_as_documented() {
        use BinOp::*;
        let order = [At, Or, And, Eq, Add, Mul, Pow];
        assert!(order.windows(2).all(|w| bin_prec(w[0]) < bin_prec(w[1])));
        assert!(bin_prec(And) < un_prec(UnOp::Not) && un_prec(UnOp::Not) < bin_prec(Eq));
        assert!(bin_prec(Mul) < un_prec(UnOp::Neg) && un_prec(UnOp::Neg) < bin_prec(Pow));
        for op in [
            Add, Sub, Mul, Div, Rem, Pow, Eq, Ne, Lt, Le, Gt, Ge, And, Or, At,
        ] {
            assert_eq!(bin_op(op.as_str()), Some(op));
        }
    }
}
