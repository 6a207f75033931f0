//! Persisting the state a run carries from step to step, for checkpoints and bit-identical
//! restart.
//!
//! Whatever holds such state (an integrator, the run driver's watches) implements one
//! `persist(&mut self, v: &mut dyn StateVisitor)` that names every value it carries from one
//! step to the next, in a fixed order. The same function saves ([`Saver`]: the visitor
//! copies the values out) and loads ([`Loader`]: the visitor overwrites them), so the two
//! cannot disagree on what is in a checkpoint or in what order. A value left out is caught
//! by the restart tests (a restarted run that is not bitwise the run straight through).
//!
//! The encoding is plain: per visited item its name, its length and its values, little
//! endian (`f64` as its bits, so every value — NaN payloads included — comes back
//! exactly). The loader checks every name and length and stops at the first difference,
//! which it reports ([`Loader::finish`]): a checkpoint of another scene or method is refused
//! instead of being read into the wrong places. The file around it (header, identity,
//! checksum, atomic write) is the run driver's (`driver/checkpoint.rs`).

use super::system::{ConstraintEval, Pose, Twist, Wrench};

/// What [`persist`](StateVisitor) functions call for each value they carry, in a fixed
/// order. Saving copies the values out; loading overwrites them.
pub trait StateVisitor {
    /// Floats.
    fn f64s(&mut self, name: &'static str, v: &mut [f64]);
    /// Counters and indices.
    fn u64s(&mut self, name: &'static str, v: &mut [u64]);
    /// Flags.
    fn bools(&mut self, name: &'static str, v: &mut [bool]);
    /// The length of a vector whose length is part of the state: saving records `n` and
    /// returns it; loading returns the saved length (the caller resizes to it).
    fn len(&mut self, name: &'static str, n: usize) -> usize;
}

/// One float.
pub fn f64(v: &mut dyn StateVisitor, name: &'static str, x: &mut f64) {
    v.f64s(name, std::slice::from_mut(x));
}

/// Several floats kept in separate fields, as one item: `fields(v)` is visited once,
/// in the order given.
pub fn f64_fields<const N: usize>(
    v: &mut dyn StateVisitor,
    name: &'static str,
    fields: [&mut f64; N],
) {
    let mut x: [f64; N] = std::array::from_fn(|i| *fields[i]);
    v.f64s(name, &mut x);
    for (f, x) in fields.into_iter().zip(x) {
        *f = x;
    }
}

/// One counter.
pub fn u64(v: &mut dyn StateVisitor, name: &'static str, x: &mut u64) {
    v.u64s(name, std::slice::from_mut(x));
}

/// One small counter or index.
pub fn u32(v: &mut dyn StateVisitor, name: &'static str, x: &mut u32) {
    let mut w = u64::from(*x);
    v.u64s(name, std::slice::from_mut(&mut w));
    *x = w as u32;
}

/// One index.
pub fn usize(v: &mut dyn StateVisitor, name: &'static str, x: &mut usize) {
    let mut w = *x as u64;
    v.u64s(name, std::slice::from_mut(&mut w));
    *x = w as usize;
}

/// A slice of indices.
pub fn usizes(v: &mut dyn StateVisitor, name: &'static str, x: &mut [usize]) {
    let mut w: Vec<u64> = x.iter().map(|&i| i as u64).collect();
    v.u64s(name, &mut w);
    for (d, s) in x.iter_mut().zip(&w) {
        *d = *s as usize;
    }
}

/// One flag.
pub fn bool(v: &mut dyn StateVisitor, name: &'static str, x: &mut bool) {
    v.bools(name, std::slice::from_mut(x));
}

/// A vector of floats whose length is part of the state.
pub fn vec_f64(v: &mut dyn StateVisitor, name: &'static str, x: &mut Vec<f64>) {
    let n = v.len(name, x.len());
    x.resize(n, 0.0);
    v.f64s(name, x);
}

/// A vector of indices whose length is part of the state.
pub fn vec_usize(v: &mut dyn StateVisitor, name: &'static str, x: &mut Vec<usize>) {
    let n = v.len(name, x.len());
    x.resize(n, 0);
    usizes(v, name, x);
}

/// A vector of flags whose length is part of the state.
pub fn vec_bool(v: &mut dyn StateVisitor, name: &'static str, x: &mut Vec<bool>) {
    let n = v.len(name, x.len());
    x.resize(n, false);
    v.bools(name, x);
}

/// A dense matrix whose shape is part of the state (a method's buffer or a matrix it
/// factors again on the next step): rows, columns, then the entries column by column.
/// Loading reshapes the matrix to the saved shape.
pub fn dmatrix(v: &mut dyn StateVisitor, name: &'static str, m: &mut nalgebra::DMatrix<f64>) {
    let r = v.len(name, m.nrows());
    let c = v.len(name, m.ncols());
    if (r, c) != m.shape() {
        *m = nalgebra::DMatrix::zeros(r, c);
    }
    v.f64s(name, m.as_mut_slice());
}

/// Visit `n` floats per item, packed by `get` and unpacked by `set`.
fn packed<T>(
    v: &mut dyn StateVisitor,
    name: &'static str,
    items: &mut [T],
    n: usize,
    get: impl Fn(&T, &mut [f64]),
    set: impl Fn(&mut T, &[f64]),
) {
    let mut buf = vec![0.0; n * items.len()];
    for (it, b) in items.iter().zip(buf.chunks_mut(n)) {
        get(it, b);
    }
    v.f64s(name, &mut buf);
    for (it, b) in items.iter_mut().zip(buf.chunks(n)) {
        set(it, b);
    }
}

/// Poses: position, quaternion and the cached rotation matrix (stored too, so that a loaded
/// pose is bitwise the saved one, not a recomputation of its matrix).
pub fn poses(v: &mut dyn StateVisitor, name: &'static str, p: &mut [Pose]) {
    packed(
        v,
        name,
        p,
        16,
        |p, b| {
            b[..3].copy_from_slice(p.r.as_slice());
            b[3..7].copy_from_slice(p.q.coords.as_slice());
            b[7..].copy_from_slice(p.c.as_slice());
        },
        |p, b| {
            p.r.as_mut_slice().copy_from_slice(&b[..3]);
            p.q.coords.as_mut_slice().copy_from_slice(&b[3..7]);
            p.c.as_mut_slice().copy_from_slice(&b[7..]);
        },
    );
}

/// Twists.
pub fn twists(v: &mut dyn StateVisitor, name: &'static str, t: &mut [Twist]) {
    packed(
        v,
        name,
        t,
        6,
        |t, b| {
            b[..3].copy_from_slice(t.v.as_slice());
            b[3..].copy_from_slice(t.w.as_slice());
        },
        |t, b| {
            t.v.as_mut_slice().copy_from_slice(&b[..3]);
            t.w.as_mut_slice().copy_from_slice(&b[3..]);
        },
    );
}

/// Wrenches.
pub fn wrenches(v: &mut dyn StateVisitor, name: &'static str, w: &mut [Wrench]) {
    packed(
        v,
        name,
        w,
        6,
        |w, b| {
            b[..3].copy_from_slice(w.f.as_slice());
            b[3..].copy_from_slice(w.t.as_slice());
        },
        |w, b| {
            w.f.as_mut_slice().copy_from_slice(&b[..3]);
            w.t.as_mut_slice().copy_from_slice(&b[3..]);
        },
    );
}

/// Constraint values, Jacobian rows, bias and γ (a method that keeps them from the end of
/// one step for the start of the next).
pub fn constraint_eval(v: &mut dyn StateVisitor, ce: &mut ConstraintEval) {
    v.f64s("ce.phi", &mut ce.phi);
    packed(
        v,
        "ce.jac",
        &mut ce.jac,
        12,
        |r, b| {
            b[..6].copy_from_slice(&r.a);
            b[6..].copy_from_slice(&r.b);
        },
        |r, b| {
            r.a.copy_from_slice(&b[..6]);
            r.b.copy_from_slice(&b[6..]);
        },
    );
    v.f64s("ce.bias", &mut ce.bias);
    v.f64s("ce.gamma", &mut ce.gamma);
}

/// Kinds of items in the encoding.
const F64: u8 = 1;
const U64: u8 = 2;
const BOOL: u8 = 3;
const LEN: u8 = 4;

/// Saves: appends every visited item to a byte vector.
#[derive(Debug, Default)]
pub struct Saver {
    bytes: Vec<u8>,
}

impl Saver {
    /// An empty saver.
    pub fn new() -> Saver {
        Saver::default()
    }

    /// The encoded items.
    pub fn into_bytes(self) -> Vec<u8> {
        self.bytes
    }

    fn head(&mut self, kind: u8, name: &str, n: usize) {
        self.bytes.push(kind);
        self.bytes.push(name.len().min(255) as u8);
        self.bytes
            .extend_from_slice(&name.as_bytes()[..name.len().min(255)]);
        self.bytes.extend_from_slice(&(n as u64).to_le_bytes());
    }
}

impl StateVisitor for Saver {
    fn f64s(&mut self, name: &'static str, v: &mut [f64]) {
        self.head(F64, name, v.len());
        for x in v.iter() {
            self.bytes.extend_from_slice(&x.to_bits().to_le_bytes());
        }
    }
    fn u64s(&mut self, name: &'static str, v: &mut [u64]) {
        self.head(U64, name, v.len());
        for x in v.iter() {
            self.bytes.extend_from_slice(&x.to_le_bytes());
        }
    }
    fn bools(&mut self, name: &'static str, v: &mut [bool]) {
        self.head(BOOL, name, v.len());
        self.bytes.extend(v.iter().map(|&b| u8::from(b)));
    }
    fn len(&mut self, name: &'static str, n: usize) -> usize {
        self.head(LEN, name, n);
        n
    }
}

/// Why loaded bytes do not fit what reads them.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum LoadError {
    /// An item has another name, kind or length than the one read in its place.
    #[error("item {index} is `{found}` ({found_len} values) where `{expected}` ({expected_len} values) is read: the state was saved by another scene, method or version")]
    Mismatch {
        /// Position of the item.
        index: usize,
        /// What is read there.
        expected: String,
        /// Its length.
        expected_len: usize,
        /// What the bytes hold there.
        found: String,
        /// Its length.
        found_len: usize,
    },
    /// The bytes end early.
    #[error("the state ends early, at item {index} (`{expected}`)")]
    Truncated {
        /// Position of the item.
        index: usize,
        /// What is read there.
        expected: String,
    },
    /// Bytes are left after the last item.
    #[error("{0} bytes are left after the last item: the state was saved by another scene, method or version")]
    Trailing(usize),
}

/// Loads: overwrites every visited item with the saved one, checking names and lengths.
/// After the first difference it reads nothing more; [`Loader::finish`] reports it.
#[derive(Debug)]
pub struct Loader<'a> {
    bytes: &'a [u8],
    at: usize,
    index: usize,
    error: Option<LoadError>,
}

impl<'a> Loader<'a> {
    /// A loader of `bytes` (from [`Saver::into_bytes`]).
    pub fn new(bytes: &'a [u8]) -> Loader<'a> {
        Loader {
            bytes,
            at: 0,
            index: 0,
            error: None,
        }
    }

    /// The first difference found, or one if bytes are left.
    pub fn finish(self) -> Result<(), LoadError> {
        match self.error {
            Some(e) => Err(e),
            None if self.at < self.bytes.len() => {
                Err(LoadError::Trailing(self.bytes.len() - self.at))
            }
            None => Ok(()),
        }
    }

    fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        let s = self.bytes.get(self.at..self.at.checked_add(n)?)?;
        self.at += n;
        Some(s)
    }

    /// Read the head of the next item; `Some(n)` (its length) if it is `name` of `kind`
    /// with `want` values (`None` for any length).
    fn head(&mut self, kind: u8, name: &str, want: Option<usize>) -> Option<usize> {
        if self.error.is_some() {
            return None;
        }
        let index = self.index;
        self.index += 1;
        let truncated = |name: &str| LoadError::Truncated {
            index,
            expected: name.to_string(),
        };
        let Some(&[k, len]) = self.take(2).map(|s| [s[0], s[1]]).as_ref() else {
            self.error = Some(truncated(name));
            return None;
        };
        let Some(found) = self
            .take(len as usize)
            .map(|s| String::from_utf8_lossy(s).into_owned())
        else {
            self.error = Some(truncated(name));
            return None;
        };
        let Some(n) = self
            .take(8)
            .map(|s| u64::from_le_bytes(s.try_into().unwrap_or([0; 8])) as usize)
        else {
            self.error = Some(truncated(name));
            return None;
        };
        if k != kind || found != name || want.is_some_and(|w| w != n) {
            self.error = Some(LoadError::Mismatch {
                index,
                expected: name.to_string(),
                expected_len: want.unwrap_or(n),
                found,
                found_len: n,
            });
            return None;
        }
        Some(n)
    }

    fn values(&mut self, name: &str, n: usize, size: usize) -> Option<&'a [u8]> {
        let s = n.checked_mul(size).and_then(|b| self.take(b));
        if s.is_none() {
            self.error = Some(LoadError::Truncated {
                index: self.index - 1,
                expected: name.to_string(),
            });
        }
        s
    }
}

impl StateVisitor for Loader<'_> {
    fn f64s(&mut self, name: &'static str, v: &mut [f64]) {
        if let Some(n) = self.head(F64, name, Some(v.len())) {
            if let Some(s) = self.values(name, n, 8) {
                for (x, b) in v.iter_mut().zip(s.chunks_exact(8)) {
                    *x = f64::from_bits(u64::from_le_bytes(b.try_into().unwrap_or([0; 8])));
                }
            }
        }
    }
    fn u64s(&mut self, name: &'static str, v: &mut [u64]) {
        if let Some(n) = self.head(U64, name, Some(v.len())) {
            if let Some(s) = self.values(name, n, 8) {
                for (x, b) in v.iter_mut().zip(s.chunks_exact(8)) {
                    *x = u64::from_le_bytes(b.try_into().unwrap_or([0; 8]));
                }
            }
        }
    }
    fn bools(&mut self, name: &'static str, v: &mut [bool]) {
        if let Some(n) = self.head(BOOL, name, Some(v.len())) {
            if let Some(s) = self.values(name, n, 1) {
                for (x, b) in v.iter_mut().zip(s) {
                    *x = *b != 0;
                }
            }
        }
    }
    fn len(&mut self, name: &'static str, n: usize) -> usize {
        // a length larger than what is left cannot be real: refuse it before a resize
        // allocates it
        match self.head(LEN, name, None) {
            Some(m) if m <= self.bytes.len() - self.at => m,
            Some(m) => {
                self.error = Some(LoadError::Truncated {
                    index: self.index - 1,
                    expected: format!("{name} ({m} values)"),
                });
                n
            }
            None => n,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Thing {
        x: f64,
        k: u64,
        on: Vec<bool>,
        list: Vec<f64>,
        poses: Vec<Pose>,
    }

    impl Thing {
        fn persist(&mut self, v: &mut dyn StateVisitor) {
            f64(v, "x", &mut self.x);
            u64(v, "k", &mut self.k);
            vec_bool(v, "on", &mut self.on);
            vec_f64(v, "list", &mut self.list);
            poses(v, "poses", &mut self.poses);
        }
    }

    fn thing() -> Thing {
        let mut p = Pose::default();
        p.r.x = 0.1;
        p.q.coords.w = f64::from_bits(0x7ff8_0000_0000_1234); // a NaN with a payload
        Thing {
            x: -0.0,
            k: u64::MAX,
            on: vec![true, false, true],
            list: vec![1.0 / 3.0, f64::INFINITY],
            poses: vec![p, Pose::default()],
        }
    }

    #[test]
    fn what_is_saved_loads_bitwise() {
        let mut a = thing();
        let mut s = Saver::new();
        a.persist(&mut s);
        let bytes = s.into_bytes();
        let mut b = Thing {
            x: 5.0,
            k: 0,
            on: Vec::new(),
            list: vec![9.0; 7],
            poses: vec![Pose::default(); 2],
        };
        let mut l = Loader::new(&bytes);
        b.persist(&mut l);
        l.finish().unwrap();
        assert_eq!(a.x.to_bits(), b.x.to_bits());
        assert_eq!(a.k, b.k);
        assert_eq!(a.on, b.on);
        assert_eq!(a.list, b.list);
        assert_eq!(
            a.poses[0].q.coords.w.to_bits(),
            b.poses[0].q.coords.w.to_bits()
        );
        assert_eq!(a.poses[0].r, b.poses[0].r);
    }

    #[test]
    fn another_shape_is_refused_by_name() {
        let mut a = thing();
        let mut s = Saver::new();
        a.persist(&mut s);
        let bytes = s.into_bytes();
        // three poses where two were saved
        let mut b = thing();
        b.poses.push(Pose::default());
        let mut l = Loader::new(&bytes);
        b.persist(&mut l);
        let e = l.finish().unwrap_err();
        assert!(e.to_string().contains("`poses`"), "{e}");
        // cut short
        let mut l = Loader::new(&bytes[..bytes.len() - 3]);
        thing().persist(&mut l);
        assert!(matches!(l.finish(), Err(LoadError::Truncated { .. })));
        // garbage never panics and never allocates a huge vector
        let junk: Vec<u8> = (0..200u32).map(|i| (i * 37 % 251) as u8).collect();
        let mut l = Loader::new(&junk);
        thing().persist(&mut l);
        assert!(l.finish().is_err());
    }
}
