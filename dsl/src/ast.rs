//! The syntax tree of a `.mbd` file.
//!
//! The tree is *generic*: the parser knows the shape of declarations, properties and
//! expressions, and a few structural forms (`import`, `param`, `const`, `component`,
//! `for`, `if`), but not what `body`, `joint` or `mass` mean. The compiler gives them
//! meaning. This keeps the syntax stable while capabilities grow.
//!
//! Every node carries a [`Span`] (byte range in its file). Equality of trees ignores
//! nothing: use [`crate::strip_spans`] (or compare formatted text) when checking that two
//! parses agree modulo layout.

/// A byte range `[start, end)` in a source file.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Span {
    /// Start byte offset.
    pub start: usize,
    /// End byte offset (exclusive).
    pub end: usize,
}

impl Span {
    /// A span from start and end offsets.
    pub fn new(start: usize, end: usize) -> Span {
        Span { start, end }
    }
    /// The smallest span covering both.
    pub fn to(self, other: Span) -> Span {
        Span {
            start: self.start.min(other.start),
            end: self.end.max(other.end),
        }
    }
}

/// An identifier with its span.
#[derive(Clone, Debug, PartialEq)]
pub struct Ident {
    /// The text.
    pub name: String,
    /// Where it is.
    pub span: Span,
}

/// A comment attached to the item that follows it (or trailing a block).
#[derive(Clone, Debug, PartialEq)]
pub struct Comment {
    /// Text including the `//` or `/* */` markers.
    pub text: String,
    /// Where it is.
    pub span: Span,
    /// Whether a blank line separates it from what comes before it in its block (layout,
    /// like the span: kept by [`format`](crate::format()), reset by
    /// [`strip_spans`](crate::strip_spans)).
    pub blank_before: bool,
}

/// A parsed file: a sequence of items.
#[derive(Clone, Debug, PartialEq)]
pub struct File {
    /// Top-level items (imports, components, consts, params, the model declaration).
    pub items: Vec<Item>,
    /// Comments after the last item.
    pub trailing_comments: Vec<Comment>,
}

/// A block `{ ... }`.
#[derive(Clone, Debug, PartialEq)]
pub struct Block {
    /// Items in order.
    pub items: Vec<Item>,
    /// Comments before the closing brace.
    pub trailing_comments: Vec<Comment>,
    /// Span of the whole block including braces.
    pub span: Span,
}

/// An item with the comments written directly above it.
#[derive(Clone, Debug, PartialEq)]
pub struct Item {
    /// Leading comments (each on its own line above the item).
    pub comments: Vec<Comment>,
    /// A comment on the same line after the item, if any.
    pub trailing_comment: Option<Comment>,
    /// What the item is.
    pub kind: ItemKind,
    /// Span of the item (excluding comments).
    pub span: Span,
    /// Whether a blank line separates the item from what comes before it (its last leading
    /// comment, or the item or comment above); layout, like `blank_before` of [`Comment`].
    pub blank_before: bool,
}

/// The kinds of items.
#[derive(Clone, Debug, PartialEq)]
pub enum ItemKind {
    /// `import "path.mbd"`
    Import {
        /// The path as written (relative to the importing file).
        path: StrLit,
    },
    /// `param NAME = expr`: a named value that may be overridden from the command line.
    Param {
        /// Name.
        name: Ident,
        /// Default value.
        value: Expr,
    },
    /// `const NAME = expr`: a named value (may depend on `t`, making it a function of time).
    Const {
        /// Name.
        name: Ident,
        /// Value.
        value: Expr,
    },
    /// `component NAME(p1, p2 = default, ...) { ... }`
    Component {
        /// Component name.
        name: Ident,
        /// Parameters with optional defaults.
        params: Vec<ComponentParam>,
        /// Body of the component.
        body: Block,
    },
    /// `for VAR in START..END { ... }` (END exclusive).
    For {
        /// Loop variable.
        var: Ident,
        /// Start (inclusive).
        start: Expr,
        /// End (exclusive).
        end: Expr,
        /// Body.
        body: Block,
    },
    /// `if COND { ... } else if ... else { ... }`
    If {
        /// Condition.
        cond: Expr,
        /// Then branch.
        then: Block,
        /// Else branch: a block, or a nested `if` item wrapped in a block.
        otherwise: Option<Block>,
    },
    /// A declaration: `KEYWORD [NAME] [= VALUE] [{ ... }]`, with at least a value or a
    /// block; a declaration without a name must have a block.
    /// Examples: `model pendulum { ... }`, `body rod { ... }`,
    /// `joint hinge = revolute(ground @ (0,0,0), rod @ (0,0,1) m, axis: (0,1,0))`,
    /// `simulate { ... }`, `method staggered { epsilon 1e-6 }`, `instance a = Link(L: 1 m)`.
    Decl {
        /// The keyword (`body`, `joint`, `model`, a component name, ...).
        keyword: Ident,
        /// The declared name, possibly indexed/dotted.
        name: Option<Name>,
        /// The value after `=`.
        value: Option<Expr>,
        /// The block.
        body: Option<Block>,
    },
    /// A property: `KEY expr, expr, ...` (possibly no values), e.g. `mass 1 kg`,
    /// `inertia diag(1, 2, 3) kg*m^2`, `include bodies, energy`, `fix left`. A property with
    /// two or more values may end with a block of options: `glue right, fine.left {
    /// traction bessel(points: 8) }` (`KEY NAME { ... }` is a declaration).
    Prop {
        /// The key.
        key: Ident,
        /// Values (comma-separated in the source).
        values: Vec<Expr>,
        /// The options block after the values, if any (only after two or more values: a
        /// tree with a block after fewer does not format to text that parses back to it).
        block: Option<Block>,
    },
}

/// A component parameter.
#[derive(Clone, Debug, PartialEq)]
pub struct ComponentParam {
    /// Name.
    pub name: Ident,
    /// Default value.
    pub default: Option<Expr>,
}

/// A declared name: `rod`, `link[i]`, `grid[i][j]`.
#[derive(Clone, Debug, PartialEq)]
pub struct Name {
    /// Base identifier.
    pub base: Ident,
    /// Index expressions, in order.
    pub indices: Vec<Expr>,
    /// Span of the whole name.
    pub span: Span,
}

/// A string literal.
#[derive(Clone, Debug, PartialEq)]
pub struct StrLit {
    /// The unescaped value.
    pub value: String,
    /// Span including quotes.
    pub span: Span,
}

/// A unit written after a number or a closing parenthesis, as one word: `m/s^2`,
/// `kg*m^2`, `N*s/m`, `1/s`.
#[derive(Clone, Debug, PartialEq)]
pub struct Unit {
    /// Factors with their (signed) exponents: `m/s^2` is `[(m, 1), (s, -2)]`.
    /// A leading `1/` contributes no factor.
    pub factors: Vec<(Ident, i32)>,
    /// The text as written (for diagnostics and formatting).
    pub text: String,
    /// Span of the unit.
    pub span: Span,
}

/// Binary operators.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BinOp {
    /// `+`
    Add,
    /// `-`
    Sub,
    /// `*`
    Mul,
    /// `/`
    Div,
    /// `%`
    Rem,
    /// `^` (right-associative, binds tighter than unary minus on its left: `-x^2 = -(x^2)`)
    Pow,
    /// `==`
    Eq,
    /// `!=`
    Ne,
    /// `<`
    Lt,
    /// `<=`
    Le,
    /// `>`
    Gt,
    /// `>=`
    Ge,
    /// `and`
    And,
    /// `or`
    Or,
    /// `@`: attachment `body @ point` (binds loosest of all).
    At,
}

impl BinOp {
    /// The operator as written.
    pub fn as_str(self) -> &'static str {
        match self {
            BinOp::Add => "+",
            BinOp::Sub => "-",
            BinOp::Mul => "*",
            BinOp::Div => "/",
            BinOp::Rem => "%",
            BinOp::Pow => "^",
            BinOp::Eq => "==",
            BinOp::Ne => "!=",
            BinOp::Lt => "<",
            BinOp::Le => "<=",
            BinOp::Gt => ">",
            BinOp::Ge => ">=",
            BinOp::And => "and",
            BinOp::Or => "or",
            BinOp::At => "@",
        }
    }
}

/// Unary operators.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum UnOp {
    /// `-x`
    Neg,
    /// `not x`
    Not,
}

/// A call argument, positional or named (`radius: 1 cm`).
#[derive(Clone, Debug, PartialEq)]
pub struct Arg {
    /// The name for a named argument.
    pub name: Option<Ident>,
    /// The value.
    pub value: Expr,
}

/// An expression with its span.
#[derive(Clone, Debug, PartialEq)]
pub struct Expr {
    /// What it is.
    pub kind: ExprKind,
    /// Where it is.
    pub span: Span,
}

/// Expression kinds.
#[derive(Clone, Debug, PartialEq)]
pub enum ExprKind {
    /// A number, with an optional unit: `9.81`, `1e-6`, `60 deg`, `9.81 m/s^2`.
    Number {
        /// The value as written.
        value: f64,
        /// The literal text (kept for the formatter, so `1e-6` stays `1e-6`).
        text: String,
        /// Unit, if any.
        unit: Option<Unit>,
    },
    /// An expression followed by a unit: `(0, 0, -9.81) m/s^2`, `(L/2) m`.
    WithUnit {
        /// The expression.
        expr: Box<Expr>,
        /// The unit.
        unit: Unit,
    },
    /// A string literal (file paths).
    Str(StrLit),
    /// `true` / `false`.
    Bool(bool),
    /// An identifier: a name, `t`, `pi`, `ground`, a keyword-like value (`body`, `world`).
    Ident(Ident),
    /// Indexing: `link[i]`.
    Index {
        /// The indexed expression.
        base: Box<Expr>,
        /// The index.
        index: Box<Expr>,
    },
    /// Member access: `arm.upper`, `v.x`.
    Member {
        /// The expression.
        base: Box<Expr>,
        /// The member.
        member: Ident,
    },
    /// A call: `sin(x)`, `revolute(a @ p, b @ q, axis: (0, 1, 0))`.
    Call {
        /// The function name.
        func: Ident,
        /// Arguments.
        args: Vec<Arg>,
    },
    /// A parenthesized tuple of two or more elements: `(x, y, z)`, `((1,0,0),(0,1,0),(0,0,1))`.
    /// `(x)` is a [`ExprKind::Paren`]; there are no one-element tuples.
    Tuple(Vec<Expr>),
    /// `(x)`.
    Paren(Box<Expr>),
    /// A list in brackets: `[(0, 0), (1, 2)]` (tables, polylines).
    List(Vec<Expr>),
    /// A unary operation.
    Unary {
        /// The operator.
        op: UnOp,
        /// The operand.
        expr: Box<Expr>,
    },
    /// A binary operation.
    Binary {
        /// The operator.
        op: BinOp,
        /// Left operand.
        lhs: Box<Expr>,
        /// Right operand.
        rhs: Box<Expr>,
    },
}
