//! Reading and parsing a file and everything it imports.
//!
//! Imports are resolved relative to the importing file. The same file imported twice
//! (a diamond) is read once; a file that imports itself, directly or through others, is an
//! import cycle and is reported with the chain of files. Imports nest at most
//! [`MAX_IMPORT_DEPTH`] deep.

use std::collections::HashMap;
use std::path::{Component, Path, PathBuf};

use mbdc_dsl::ast::{self, ItemKind, Span};

use crate::diag::{codes, Diagnostic};
use crate::source::{FileId, Sources};

/// Deepest chain of imports accepted.
pub const MAX_IMPORT_DEPTH: usize = 32;

/// Largest `.mbd` file read (the main file or an import): 64 MiB.
pub const MAX_SOURCE_BYTES: u64 = 64 << 20;

/// Largest `.msh` mesh file read: 512 MiB.
pub const MAX_MESH_BYTES: u64 = 512 << 20;

/// Reads a file's text (the file system, or a virtual one in tests).
pub type Reader<'r> = &'r dyn Fn(&Path) -> std::io::Result<String>;

/// Reads an input file's text, refusing what is not a regular file and what is larger than
/// `limit` bytes.
///
/// A character device (`/dev/zero`), a FIFO or a socket would be read forever, or block
/// until a writer comes; a directory has no text. They are refused by their kind before the
/// file is opened. The size is checked before reading and again while reading (a file that
/// grows, or a special file that reports size 0, stops at `limit + 1` bytes).
///
/// # Errors
/// The file's own error (`NotFound`, …), or `InvalidInput` with a message saying what the
/// file is or how large it is against the limit; callers print it after the file's name.
pub fn read_input(path: &Path, limit: u64) -> std::io::Result<String> {
    use std::io::Read;
    let meta = std::fs::metadata(path)?;
    if !meta.is_file() {
        return Err(invalid(format!(
            "{} is not a regular file",
            mbdc_runtime::study::table::file_kind(&meta.file_type())
        )));
    }
    let too_large = |size: u64| {
        invalid(format!(
            "the file has {size} bytes, more than the {} MiB mbdc reads",
            limit >> 20
        ))
    };
    if meta.len() > limit {
        return Err(too_large(meta.len()));
    }
    let mut bytes = Vec::new();
    std::fs::File::open(path)?
        .take(limit + 1)
        .read_to_end(&mut bytes)?;
    if bytes.len() as u64 > limit {
        return Err(too_large(bytes.len() as u64));
    }
    String::from_utf8(bytes).map_err(|_| invalid("the file is not UTF-8 text".into()))
}

fn invalid(message: String) -> std::io::Error {
    std::io::Error::new(std::io::ErrorKind::InvalidInput, message)
}

/// One import statement after resolution.
#[derive(Clone, Debug)]
pub(crate) struct ImportRef {
    /// Index into the loaded files, `None` if it could not be loaded (already reported).
    pub target: Option<usize>,
    /// Span of the path string.
    pub span: Span,
}

/// A parsed file.
#[derive(Debug)]
pub(crate) struct ParsedFile {
    /// Its id in the source map.
    pub id: FileId,
    /// The syntax tree (`None` if it did not parse).
    pub ast: Option<ast::File>,
    /// Its imports, in order.
    pub imports: Vec<ImportRef>,
    /// Directory its relative paths are resolved in (None: current directory).
    pub dir: Option<PathBuf>,
    /// The display name of its directory (for naming imported files in messages).
    pub name_dir: PathBuf,
}

/// Converts a parse error to a diagnostic.
pub fn parse_diagnostic(e: &mbdc_dsl::ParseError, file: FileId) -> Diagnostic {
    Diagnostic::error(codes::SYNTAX, e.message.clone())
        .primary(file, e.span, "")
        .maybe_help(e.help.clone())
}

/// Lexically normalises `a/./b/../c` to `a/c` (for display names).
pub fn normalize(p: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for c in p.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => {
                if !out.pop() {
                    out.push("..");
                }
            }
            c => out.push(c.as_os_str()),
        }
    }
    out
}

pub(crate) struct Loader<'r, 's> {
    pub sources: &'s mut Sources,
    pub diags: Vec<Diagnostic>,
    pub files: Vec<ParsedFile>,
    by_path: HashMap<PathBuf, usize>,
    stack: Vec<(usize, Span)>,
    reader: Reader<'r>,
}

impl<'r, 's> Loader<'r, 's> {
    pub fn new(sources: &'s mut Sources, reader: Reader<'r>) -> Self {
        Loader {
            sources,
            diags: Vec::new(),
            files: Vec::new(),
            by_path: HashMap::new(),
            stack: Vec::new(),
            reader,
        }
    }

    /// Adds a text as a file, parses it, and loads its imports recursively.
    pub fn load_root(&mut self, name: &str, path: Option<PathBuf>, text: String) -> usize {
        let name_dir = Path::new(name)
            .parent()
            .map(Path::to_path_buf)
            .unwrap_or_default();
        let dir = match &path {
            Some(p) => p.parent().map(Path::to_path_buf),
            None => Some(name_dir.clone()).filter(|d| !d.as_os_str().is_empty()),
        };
        let key = path.clone();
        let idx = self.add(name.to_string(), path, text, dir, name_dir);
        if let Some(k) = key {
            self.by_path.insert(k, idx);
        }
        self.visit(idx, 0);
        idx
    }

    fn add(
        &mut self,
        name: String,
        path: Option<PathBuf>,
        text: String,
        dir: Option<PathBuf>,
        name_dir: PathBuf,
    ) -> usize {
        let id = self.sources.add(name, path, text.clone());
        let ast = match mbdc_dsl::parse(&text) {
            Ok(f) => Some(f),
            Err(errs) => {
                for e in &errs {
                    self.diags.push(parse_diagnostic(e, id));
                }
                if errs.is_empty() {
                    self.diags.push(
                        Diagnostic::error(codes::SYNTAX, "the file does not parse").primary(
                            id,
                            Span::new(0, 0),
                            "",
                        ),
                    );
                }
                None
            }
        };
        self.files.push(ParsedFile {
            id,
            ast,
            imports: Vec::new(),
            dir,
            name_dir,
        });
        self.files.len() - 1
    }

    fn visit(&mut self, idx: usize, depth: usize) {
        let imports: Vec<(String, Span)> = match &self.files[idx].ast {
            Some(f) => f
                .items
                .iter()
                .filter_map(|it| match &it.kind {
                    ItemKind::Import { path } => Some((path.value.clone(), path.span)),
                    _ => None,
                })
                .collect(),
            None => Vec::new(),
        };
        let file_id = self.files[idx].id;
        for (rel, span) in imports {
            let target = self.import(idx, file_id, &rel, span, depth);
            self.files[idx].imports.push(ImportRef { target, span });
        }
    }

    fn import(
        &mut self,
        idx: usize,
        file_id: FileId,
        rel: &str,
        span: Span,
        depth: usize,
    ) -> Option<usize> {
        let (dir, name_dir) = (
            self.files[idx].dir.clone(),
            self.files[idx].name_dir.clone(),
        );
        let joined = match &dir {
            Some(d) => d.join(rel),
            None => PathBuf::from(rel),
        };
        let display = normalize(&name_dir.join(rel));
        let display_s = display.to_string_lossy().replace('\\', "/");
        let canonical = match joined.canonicalize() {
            Ok(p) => p,
            Err(e) => {
                self.diags.push(
                    Diagnostic::error(
                        codes::IMPORT,
                        format!("cannot read `{display_s}`: {}", io_reason(&e)),
                    )
                    .primary(file_id, span, "imported here")
                    .help("import paths are relative to the importing file"),
                );
                return None;
            }
        };
        if let Some(&j) = self.by_path.get(&canonical) {
            if j == idx || self.stack_contains(j) {
                self.report_cycle(idx, j, span);
                return None;
            }
            return Some(j);
        }
        if depth + 1 > MAX_IMPORT_DEPTH {
            self.diags.push(
                Diagnostic::error(
                    codes::IMPORT,
                    format!("imports nest more than {MAX_IMPORT_DEPTH} files deep"),
                )
                .primary(file_id, span, "too deep"),
            );
            return None;
        }
        let text = match (self.reader)(&canonical) {
            Ok(t) => t,
            Err(e) => {
                self.diags.push(
                    Diagnostic::error(
                        codes::IMPORT,
                        format!("cannot read `{display_s}`: {}", io_reason(&e)),
                    )
                    .primary(file_id, span, "imported here"),
                );
                return None;
            }
        };
        let new_dir = canonical.parent().map(Path::to_path_buf);
        let new_name_dir = display.parent().map(Path::to_path_buf).unwrap_or_default();
        let j = self.add(
            display_s,
            Some(canonical.clone()),
            text,
            new_dir,
            new_name_dir,
        );
        self.by_path.insert(canonical, j);
        self.stack.push((idx, span));
        self.visit(j, depth + 1);
        self.stack.pop();
        Some(j)
    }

    fn stack_contains(&self, j: usize) -> bool {
        self.stack.iter().any(|(i, _)| *i == j)
    }

    fn report_cycle(&mut self, idx: usize, j: usize, span: Span) {
        // The chain: from j's position on the stack (or idx itself) to idx, then back to j.
        let mut chain: Vec<(usize, Span)> = Vec::new();
        if let Some(pos) = self.stack.iter().position(|(i, _)| *i == j) {
            chain.extend(self.stack[pos..].iter().copied());
        }
        chain.push((idx, span));
        let mut names: Vec<String> = chain
            .iter()
            .map(|(i, _)| self.sources.name(self.files[*i].id).to_string())
            .collect();
        names.push(self.sources.name(self.files[j].id).to_string());
        let this = self.files[idx].id;
        let mut d = Diagnostic::error(
            codes::IMPORT_CYCLE,
            format!("import cycle: {}", names.join(" → ")),
        )
        .primary(this, span, "this import closes the cycle");
        for (i, s) in &chain[..chain.len() - 1] {
            d = d.secondary(self.files[*i].id, *s, "imported here");
        }
        self.diags
            .push(d.help("move the shared items into a file that neither imports"));
    }
}

fn io_reason(e: &std::io::Error) -> String {
    match e.kind() {
        std::io::ErrorKind::NotFound => "no such file".into(),
        std::io::ErrorKind::PermissionDenied => "permission denied".into(),
        _ => e.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normalizes() {
        assert_eq!(
            normalize(Path::new("a/./b/../c.mbd")),
            PathBuf::from("a/c.mbd")
        );
        assert_eq!(normalize(Path::new("../x.mbd")), PathBuf::from("../x.mbd"));
    }
}
