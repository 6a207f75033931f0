//! The linear solvers and the output writer do not allocate in their per-step methods:
//! checked with a counting global allocator (per thread, so the output writer's own
//! thread, which formats and allocates freely, is not counted).

use std::alloc::{GlobalAlloc, Layout as AllocLayout, System as Sys};
use std::cell::Cell;

use mbdc_runtime::linalg::{
    Backend, BackendKind, ColumnSelector, Definiteness, DenseLu, KSolver, KSolverOptions,
    PivotedCholesky,
};
use mbdc_runtime::output::{OutputWriter, RunMeta, Summary};
use mbdc_runtime::scene::OutputSpec;
use mbdc_runtime::system::{JointLayout, Layout, MassProps, RowJac, RowKind};
use nalgebra::{DMatrix, Matrix3};

struct Counting;

thread_local! {
    static COUNT: Cell<usize> = const { Cell::new(0) };
}

fn bump() {
    let _ = COUNT.try_with(|c| c.set(c.get() + 1));
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: AllocLayout) -> *mut u8 {
        bump();
        unsafe { Sys.alloc(l) }
    }
    unsafe fn alloc_zeroed(&self, l: AllocLayout) -> *mut u8 {
        bump();
        unsafe { Sys.alloc_zeroed(l) }
    }
    unsafe fn realloc(&self, p: *mut u8, l: AllocLayout, n: usize) -> *mut u8 {
        bump();
        unsafe { Sys.realloc(p, l, n) }
    }
    unsafe fn dealloc(&self, p: *mut u8, l: AllocLayout) {
        unsafe { Sys.dealloc(p, l) }
    }
}

#[global_allocator]
static A: Counting = Counting;

fn allocations<R>(f: impl FnOnce() -> R) -> (R, usize) {
    let before = COUNT.with(|c| c.get());
    let r = f();
    (r, COUNT.with(|c| c.get()) - before)
}

/// A chain of `n` bodies with 3-row joints plus one redundant joint repeating the first.
fn chain(n: usize) -> (Layout, Vec<RowJac>) {
    let mp = MassProps::new(
        2.0,
        Matrix3::new(1.0, 0.1, 0.0, 0.1, 2.0, 0.0, 0.0, 0.0, 3.0),
    )
    .unwrap();
    let mut joints: Vec<JointLayout> = (0..n)
        .map(|i| JointLayout {
            name: format!("j{i}"),
            kind: "spherical",
            a: if i == 0 { None } else { Some(i - 1) },
            b: Some(i),
            first_row: 3 * i,
            rows: 3,
            nonholonomic: 0,
            starts_inactive: false,
        })
        .collect();
    joints.push(JointLayout {
        name: "dup".into(),
        first_row: 3 * n,
        ..joints[0].clone()
    });
    let rows = 3 * n + 3;
    let layout = Layout {
        body_names: (0..n).map(|i| format!("b{i}")).collect(),
        mass: vec![mp; n],
        row_joint: (0..rows).map(|r| r / 3).collect(),
        row_kind: vec![RowKind::Holonomic; rows],
        beams: Default::default(),
        meshes: Default::default(),
        joints,
        rows,
    };
    let mut jac: Vec<RowJac> = (0..rows)
        .map(|r| {
            let mut j = RowJac::default();
            for k in 0..6 {
                j.a[k] = ((r * 7 + k * 3) % 11) as f64 - 5.0;
                j.b[k] = ((r * 5 + k * 13) % 17) as f64 - 8.0 + if k == r % 6 { 20.0 } else { 0.0 };
            }
            j
        })
        .collect();
    for k in 0..3 {
        jac[3 * n + k] = jac[k];
    }
    (layout, jac)
}

#[test]
fn k_solvers_do_not_allocate() {
    for (n, backend) in [
        (5, Backend::Dense),
        (200, Backend::Sparse),
        (200, Backend::Auto),
    ] {
        let (layout, jac) = chain(n);
        for definiteness in [
            Definiteness::Positive,
            Definiteness::SemiDefinite { tol: 1e-12 },
        ] {
            let mut s = KSolver::new(
                &layout,
                KSolverOptions {
                    backend,
                    definiteness,
                },
            )
            .unwrap();
            let mut rhs = vec![1.0; layout.rows];
            // Positive mode: shift makes the redundant K definite.
            let shift = if definiteness == Definiteness::Positive {
                1e-6
            } else {
                0.0
            };
            let (stats, count) = allocations(|| {
                let mut last = None;
                for _ in 0..3 {
                    s.assemble(&jac, &layout.mass, 0.5, shift, None);
                    last = Some(s.factor().unwrap());
                    s.solve_in_place(&mut rhs);
                }
                last.unwrap()
            });
            assert_eq!(
                count,
                0,
                "{backend:?} {definiteness:?} ({:?}) allocated",
                s.backend()
            );
            if shift == 0.0 {
                assert_eq!(stats.rank, layout.rows - 3, "{:?}", s.backend());
                assert_eq!(s.dependent_rows().len(), 3);
            }
            if backend == Backend::Sparse {
                assert_eq!(s.backend(), BackendKind::Sparse);
            }
        }
    }
}

#[test]
fn dense_factorizations_do_not_allocate() {
    for n in [4usize, 150] {
        let a = DMatrix::from_fn(n, n, |i, j| {
            if i == j {
                4.0 + i as f64
            } else {
                1.0 / (1.0 + (i + 2 * j) as f64)
            }
        });
        let spd = &a * a.transpose();
        let mut lu = DenseLu::new(n);
        let mut piv = PivotedCholesky::new(n, 1e-12);
        let mut sel = ColumnSelector::new(n / 2, n, 1e-10);
        let b = a.rows(0, n / 2).into_owned();
        let mut x = vec![1.0; n];
        let ((), count) = allocations(|| {
            lu.factor(&a).unwrap();
            lu.solve_in_place(&mut x);
            lu.solve_transpose_in_place(&mut x);
            piv.factor(&spd).unwrap();
            piv.solve_in_place(&mut x);
            assert_eq!(sel.select(&b).unwrap().rank, n / 2);
        });
        assert_eq!(count, 0, "n = {n}");
    }
}

#[test]
fn output_frames_do_not_allocate_on_the_simulation_thread() {
    let dir = tempfile::tempdir().unwrap();
    let (layout, _) = chain(50);
    let spec = OutputSpec {
        every: 1,
        bodies: true,
        energy: true,
        constraints: true,
        ..OutputSpec::default()
    };
    let meta = RunMeta {
        model: "chain".into(),
        method: "staggered".into(),
        step: 1e-3,
        duration: 1.0,
    };
    let mut w = OutputWriter::create(dir.path(), &layout, &spec, meta.clone()).unwrap();
    let phi = vec![1e-9; layout.rows];
    let lambda = vec![0.5; layout.rows];
    let mut step = 0u64;
    let mut one = |w: &mut OutputWriter| {
        let mut f = w.frame();
        f.step = step;
        f.t = step as f64 * 1e-3;
        f.kinetic = 1.0;
        f.poses[3].r.x = f.t;
        f.set_constraints(&layout, &phi, &phi, &lambda, None);
        w.submit(f).unwrap();
        step += 1;
    };
    // From the first frame on (the writer warmed up the channel's wait path).
    let ((), count) = allocations(|| {
        for _ in 0..10_000 {
            one(&mut w);
        }
    });
    assert_eq!(count, 0);
    let s = w.finish(&Summary::started(&meta)).unwrap();
    assert_eq!(s.frames, 10_000);
}
