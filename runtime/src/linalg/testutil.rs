//! Test helpers: a deterministic RNG, layouts of chains/trees/loops, random Jacobians and
//! dense references.

use nalgebra::{DMatrix, Matrix3};

use crate::contract::system::{JointLayout, Layout, MassProps, RowJac, RowKind};

/// SplitMix64: small, deterministic, good enough for test matrices.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Rng {
        Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0xD1B5_4A32_D192_ED03)
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Standard normal (Box–Muller).
    pub fn normal(&mut self) -> f64 {
        let u1 = self.uniform().max(1e-300);
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }
    /// Uniform integer in `0..n`.
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
}

/// Mass properties with a random diagonally dominant inertia.
pub fn random_mass(rng: &mut Rng) -> MassProps {
    let m = 0.5 + 2.0 * rng.uniform();
    let mut j = Matrix3::zeros();
    for i in 0..3 {
        for k in 0..3 {
            j[(i, k)] = 0.05 * rng.normal();
        }
    }
    let j = (j + j.transpose()) * 0.5 + Matrix3::identity() * (0.5 + rng.uniform());
    MassProps::new(m, j).expect("invertible inertia")
}

/// A layout from joints given as (a, b, rows).
pub fn layout_from_joints(
    rng: &mut Rng,
    bodies: usize,
    joints: &[(Option<usize>, Option<usize>, usize)],
) -> Layout {
    let mut jl = Vec::new();
    let mut row_joint = Vec::new();
    let mut first = 0;
    for (k, &(a, b, rows)) in joints.iter().enumerate() {
        jl.push(JointLayout {
            name: format!("j{k}"),
            kind: "spherical",
            a,
            b,
            first_row: first,
            rows,
            nonholonomic: 0,
            starts_inactive: false,
        });
        row_joint.extend(std::iter::repeat_n(k, rows));
        first += rows;
    }
    Layout {
        body_names: (0..bodies).map(|i| format!("b{i}")).collect(),
        mass: (0..bodies).map(|_| random_mass(rng)).collect(),
        joints: jl,
        rows: first,
        row_joint,
        row_kind: vec![RowKind::Holonomic; first],
        beams: Default::default(),
        meshes: Default::default(),
    }
}

/// A chain: ground–0, 0–1, …, each joint with `rows` rows.
pub fn chain_layout(bodies: usize, rows: usize) -> Layout {
    let mut rng = Rng::new(bodies as u64);
    let joints: Vec<_> = (0..bodies)
        .map(|i| (if i == 0 { None } else { Some(i - 1) }, Some(i), rows))
        .collect();
    layout_from_joints(&mut rng, bodies, &joints)
}

/// A random tree (each body hangs off ground or an earlier body), plus `extra` loop
/// joints between random bodies (or ground) if `loops`.
pub fn random_layout(rng: &mut Rng, bodies: usize, _rows_hint: usize, loops: bool) -> Layout {
    let mut joints = Vec::new();
    for i in 0..bodies {
        let parent = if i == 0 || rng.uniform() < 0.15 {
            None
        } else {
            Some(rng.below(i))
        };
        joints.push((parent, Some(i), 1 + rng.below(6)));
    }
    if loops {
        for _ in 0..bodies / 3 + 1 {
            let a = rng.below(bodies);
            let b = if rng.uniform() < 0.2 {
                None
            } else {
                Some(rng.below(bodies))
            };
            joints.push((Some(a), b, 1 + rng.below(3)));
        }
    }
    layout_from_joints(rng, bodies, &joints)
}

/// A ladder: two chains of `n` bodies from ground, rungs between body i of each.
pub fn ladder_layout(n: usize, rows: usize) -> Layout {
    let mut rng = Rng::new(99 + n as u64);
    let mut joints = Vec::new();
    for side in 0..2 {
        for i in 0..n {
            let body = side * n + i;
            joints.push((if i == 0 { None } else { Some(body - 1) }, Some(body), rows));
        }
    }
    for i in 1..n {
        joints.push((Some(i), Some(n + i), rows));
    }
    layout_from_joints(&mut rng, 2 * n, &joints)
}

/// A star: ground–hub, and `n` bodies each joined to the hub (every row shares the hub,
/// so `K` is dense).
pub fn star_layout(n: usize, rows: usize) -> Layout {
    let mut rng = Rng::new(7 + n as u64);
    let mut joints = vec![(None, Some(0), rows)];
    for i in 1..=n {
        joints.push((Some(0), Some(i), rows));
    }
    layout_from_joints(&mut rng, n + 1, &joints)
}

/// Random Jacobian rows.
pub fn random_jac(rng: &mut Rng, rows: usize) -> Vec<RowJac> {
    (0..rows)
        .map(|_| {
            let mut j = RowJac::default();
            for k in 0..6 {
                j.a[k] = rng.normal();
                j.b[k] = rng.normal();
            }
            j
        })
        .collect()
}

/// The dense `m × 6n` Jacobian.
pub fn dense_b(layout: &Layout, jac: &[RowJac]) -> DMatrix<f64> {
    let mut b = DMatrix::zeros(layout.rows, 6 * layout.bodies());
    for r in 0..layout.rows {
        let (ba, bb) = layout.row_bodies(r);
        if let Some(a) = ba {
            for k in 0..6 {
                b[(r, 6 * a + k)] += jac[r].a[k];
            }
        }
        if let Some(bb) = bb {
            for k in 0..6 {
                b[(r, 6 * bb + k)] += jac[r].b[k];
            }
        }
    }
    b
}

/// The dense `M⁻¹`.
pub fn dense_minv(layout: &Layout) -> DMatrix<f64> {
    let n = layout.bodies();
    let mut m = DMatrix::zeros(6 * n, 6 * n);
    for (i, mp) in layout.mass.iter().enumerate() {
        for k in 0..3 {
            m[(6 * i + k, 6 * i + k)] = 1.0 / mp.m;
            for l in 0..3 {
                m[(6 * i + 3 + k, 6 * i + 3 + l)] = mp.j_inv[(k, l)];
            }
        }
    }
    m
}

/// A random SPD matrix `Q diag(eig) Qᵀ` with the given eigenvalues.
pub fn spd_with_eigenvalues(rng: &mut Rng, eig: &[f64]) -> DMatrix<f64> {
    let n = eig.len();
    let g = DMatrix::from_fn(n, n, |_, _| rng.normal());
    let q = g.qr().q();
    &q * DMatrix::from_diagonal(&nalgebra::DVector::from_column_slice(eig)) * q.transpose()
}

/// Relative residual `‖A x − b‖∞ / (‖A‖∞ ‖x‖∞ + ‖b‖∞)`.
pub fn rel_residual(a: &DMatrix<f64>, x: &[f64], b: &[f64]) -> f64 {
    let xv = nalgebra::DVector::from_column_slice(x);
    let bv = nalgebra::DVector::from_column_slice(b);
    let r = a * &xv - &bv;
    let anorm = a
        .row_iter()
        .map(|row| row.iter().map(|v| v.abs()).sum::<f64>())
        .fold(0.0, f64::max);
    r.amax() / (anorm * xv.amax() + bv.amax())
}
