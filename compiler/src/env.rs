//! Lexical environments: persistent linked frames, one binding each, so that a
//! declaration can capture the names visible at its position cheaply.

use std::rc::Rc;

use mbdc_dsl::ast::Span;

use crate::source::FileId;
use crate::value::Value;

/// What introduced a binding.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BindKind {
    /// `param`
    Param,
    /// `const`
    Const,
    /// A `for` loop variable.
    LoopVar,
    /// A component parameter.
    ComponentParam,
    /// A variable bound by the compiler (`x` in curves and node predicates).
    Builtin,
    /// A `const` or `param` whose value could not be computed: its error is reported, and
    /// its uses are errors that are not reported again (as rustc does), so that one bad
    /// value does not bury the real error under an "unknown name" at every use.
    Failed,
}

/// One binding.
#[derive(Debug)]
pub struct Frame {
    /// Name.
    pub name: String,
    /// Value.
    pub value: Value,
    /// What introduced it.
    pub kind: BindKind,
    /// Where it was declared.
    pub file: FileId,
    /// Span of the declaring name.
    pub span: Span,
    parent: Env,
}

impl Drop for Frame {
    fn drop(&mut self) {
        // Unlink iteratively so that long chains do not overflow the stack.
        let mut next = self.parent.0.take();
        while let Some(rc) = next {
            match Rc::try_unwrap(rc) {
                Ok(mut f) => next = f.parent.0.take(),
                Err(_) => break,
            }
        }
    }
}

/// An environment: the innermost frame, or empty.
#[derive(Clone, Debug, Default)]
pub struct Env(Option<Rc<Frame>>);

impl Env {
    /// The empty environment.
    pub fn empty() -> Env {
        Env(None)
    }

    /// A new environment with one more binding.
    pub fn bind(
        &self,
        name: impl Into<String>,
        value: Value,
        kind: BindKind,
        file: FileId,
        span: Span,
    ) -> Env {
        Env(Some(Rc::new(Frame {
            name: name.into(),
            value,
            kind,
            file,
            span,
            parent: self.clone(),
        })))
    }

    /// The innermost binding of a name.
    pub fn get(&self, name: &str) -> Option<&Frame> {
        let mut cur = self.0.as_deref();
        while let Some(f) = cur {
            if f.name == name {
                return Some(f);
            }
            cur = f.parent.0.as_deref();
        }
        None
    }

    /// All visible names (innermost first, duplicates included).
    pub fn names(&self) -> Vec<&str> {
        let mut out = Vec::new();
        let mut cur = self.0.as_deref();
        while let Some(f) = cur {
            out.push(f.name.as_str());
            cur = f.parent.0.as_deref();
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::value::Q;

    #[test]
    fn shadowing_and_long_chains() {
        let mut e = Env::empty();
        for i in 0..200_000 {
            e = e.bind(
                format!("n{}", i % 7),
                Value::Num(Q::num(i as f64)),
                BindKind::Const,
                FileId(0),
                Span::default(),
            );
        }
        let Value::Num(q) = &e.get("n0").unwrap().value else {
            panic!()
        };
        assert_eq!(q.constant(), Some(199_997.0));
        assert!(e.get("zz").is_none());
        drop(e);
    }
}
