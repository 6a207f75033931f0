//! The beams' element kernels, chosen once before a run: one function per element variant,
//! monomorphized ([`element_forces::<DAMPED>`](element_forces)), so that an undamped beam's
//! elements run no damping code and a damped beam's compute their frame once for the
//! elastic and the damping forces.
//!
//! [`BeamKernels`] is the table of the variants a system uses. The interpreter's table is
//! built at run time from the beams' damping ([`BeamKernels::interpreted`]); generated
//! code writes its own, naming only the variants its beams use
//! (`BeamKernel::elastic()`, `BeamKernel::damped()`), and hands it to the integrators
//! through [`System::beam_kernels`](crate::contract::system::System::beam_kernels), typed
//! `Any` for the same reason as the meshes' table ([`super::mesh_kernels`]): an entry is a
//! function of the element kernel's types, which the contract floor may not name. Each
//! beam then runs the entry of its variant ([`BeamKernels::per_beam`]); the section
//! constants and the damping coefficient stay data, so a `--set` of a number does not
//! change the code. Both tables call the same functions, so the two paths agree bitwise.

use std::borrow::Cow;

use crate::contract::system::{BeamLayout, System, Wrench};
use crate::kernels::beam_element::{
    element_forces, BeamError, BeamNode, BeamSection, ElementState,
};

/// One element's force evaluation: section, damping coefficient β (s), the element's state
/// (advanced in place), its two nodes, the forces on them (out). Returns the element's
/// relative section turn (see [`element_forces`]).
pub type ElementFn = fn(
    &BeamSection,
    f64,
    &mut ElementState,
    &[BeamNode; 2],
    &mut [Wrench; 2],
) -> Result<f64, BeamError>;

/// One element variant and its function.
#[derive(Clone, Copy, Debug)]
pub struct BeamKernel {
    /// Whether the variant adds stiffness-proportional damping (`damping β` with β > 0).
    pub damped: bool,
    /// The element's force evaluation.
    pub run: ElementFn,
}

impl BeamKernel {
    /// The undamped element: [`element_forces::<false>`](element_forces).
    pub const fn elastic() -> BeamKernel {
        BeamKernel {
            damped: false,
            run: element_forces::<false>,
        }
    }

    /// The element with stiffness-proportional damping:
    /// [`element_forces::<true>`](element_forces).
    pub const fn damped() -> BeamKernel {
        BeamKernel {
            damped: true,
            run: element_forces::<true>,
        }
    }

    /// The variant of a beam with damping coefficient `beta`.
    pub fn of(beta: f64) -> BeamKernel {
        if is_damped(beta) {
            BeamKernel::damped()
        } else {
            BeamKernel::elastic()
        }
    }
}

/// Whether a beam with damping coefficient `beta` runs the damped variant.
pub fn is_damped(beta: f64) -> bool {
    beta != 0.0
}

/// The element variants of a system's beams, each once.
#[derive(Clone, Debug)]
pub struct BeamKernels(Cow<'static, [BeamKernel]>);

impl BeamKernels {
    /// A table written in code (generated code's `static`).
    pub const fn new(kernels: &'static [BeamKernel]) -> BeamKernels {
        BeamKernels(Cow::Borrowed(kernels))
    }

    /// The interpreter's table: the variants of `beams`, in order of first appearance.
    pub fn interpreted(beams: &BeamLayout) -> BeamKernels {
        let mut v: Vec<BeamKernel> = Vec::new();
        for b in &beams.beams {
            let k = BeamKernel::of(b.damping);
            if !v.iter().any(|x| x.damped == k.damped) {
                v.push(k);
            }
        }
        BeamKernels(Cow::Owned(v))
    }

    /// The variants, in table order.
    pub fn kernels(&self) -> &[BeamKernel] {
        &self.0
    }

    /// Each beam's element function (in the order of `beams`), or the first beam whose
    /// variant the table lacks (its index and what is missing).
    pub fn per_beam(&self, beams: &BeamLayout) -> Result<Vec<ElementFn>, (usize, String)> {
        beams
            .beams
            .iter()
            .enumerate()
            .map(|(i, b)| {
                let damped = is_damped(b.damping);
                self.0
                    .iter()
                    .find(|k| k.damped == damped)
                    .map(|k| k.run)
                    .ok_or_else(|| {
                        (
                            i,
                            format!(
                                "the element kernels of the system have no {} variant, and the beam's damping is {} s (a bug in the code that implements `System::beam_kernels`)",
                                if damped { "damped" } else { "undamped" },
                                b.damping
                            ),
                        )
                    })
            })
            .collect()
    }

    /// The table of `sys`: its own (generated code) or, without one, the interpreter's.
    /// Errors when the system's table is not a [`BeamKernels`].
    pub fn of_system<S: System + ?Sized>(sys: &S) -> Result<BeamKernels, String> {
        match sys.beam_kernels() {
            Some(k) => k.downcast_ref::<BeamKernels>().cloned().ok_or_else(|| {
                "the system's beam kernels are not a `BeamKernels` table (a bug in the code that implements it)".to_string()
            }),
            None => Ok(BeamKernels::interpreted(&sys.layout().beams)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contract::math::quat_from_rotation;
    use crate::contract::system::{Pose, Twist};
    use crate::kernels::beam_element::{internal_force, ElementForce};
    use nalgebra::{Matrix3, Rotation3, Vector3};

    fn section() -> BeamSection {
        BeamSection {
            ea: 2.1e8,
            ga2: 7e7,
            ga3: 6e7,
            gj: 3e3,
            ei2: 5e3,
            ei3: 4e3,
            rho_a: 15.7,
            rho_j: Vector3::new(1e-3, 6e-4, 4e-4),
        }
    }

    fn node(x: Vector3<f64>, c: Matrix3<f64>, v: Vector3<f64>, w: Vector3<f64>) -> BeamNode {
        BeamNode {
            pose: Pose::new(x, quat_from_rotation(&c)),
            twist: Twist { v, w },
        }
    }

    /// The interpreter's table lists each variant once, in order of first appearance; a
    /// table without a beam's variant names that beam.
    #[test]
    fn tables_list_variants_once_and_name_a_missing_one() {
        use crate::contract::system::{BeamInfo, BeamLayout};
        let beam = |name: &str, damping: f64| BeamInfo {
            name: name.into(),
            first_element: 0,
            elements: 1,
            first_body: 0,
            section: crate::contract::scene::Section {
                ea: 1.0,
                ga2: 1.0,
                ga3: 1.0,
                gj: 1.0,
                ei2: 1.0,
                ei3: 1.0,
                rho_a: 1.0,
                rho_i: 1.0,
            },
            damping,
            rotary_inertia_scale: 1.0,
        };
        let layout = BeamLayout {
            beams: vec![
                beam("a", 0.0),
                beam("b", 1e-6),
                beam("c", 0.0),
                beam("d", 2e-6),
            ],
            ..BeamLayout::default()
        };
        let t = BeamKernels::interpreted(&layout);
        let damped: Vec<bool> = t.kernels().iter().map(|k| k.damped).collect();
        assert_eq!(damped, [false, true]);
        assert_eq!(t.per_beam(&layout).map(|v| v.len()), Ok(4));
        static ELASTIC_ONLY: [BeamKernel; 1] = [BeamKernel::elastic()];
        let (b, why) = BeamKernels::new(&ELASTIC_ONLY)
            .per_beam(&layout)
            .expect_err("b has no variant");
        assert_eq!(b, 1);
        assert!(why.contains("no damped variant"), "{why}");
    }

    /// Both variants give, bit for bit, what the element kernel and a damping evaluation
    /// that recomputes the frame give (the interpreter's sum before the variants existed):
    /// elastic = `internal_force`'s wrenches, damped = those plus `β ℓ Bᵀ C ε̇`.
    #[test]
    fn variants_match_the_kernel_and_the_separate_damping() {
        let sec = section();
        let rest = [
            node(
                Vector3::zeros(),
                Matrix3::identity(),
                Vector3::zeros(),
                Vector3::zeros(),
            ),
            node(
                Vector3::new(0.5, 0.0, 0.0),
                Matrix3::identity(),
                Vector3::zeros(),
                Vector3::zeros(),
            ),
        ];
        let r2 = Rotation3::from_scaled_axis(Vector3::new(0.01, -0.02, 0.03)).into_inner();
        let moved = [
            node(
                Vector3::new(1e-4, 0.0, 2e-4),
                Matrix3::identity(),
                Vector3::new(0.1, 0.2, 0.0),
                Vector3::new(0.0, 0.3, 0.1),
            ),
            node(
                Vector3::new(0.5003, 0.001, -0.002),
                r2,
                Vector3::new(-0.1, 0.0, 0.4),
                Vector3::new(0.2, 0.0, -0.5),
            ),
        ];
        let beta = 2e-4;
        for damped in [false, true] {
            let k = if damped {
                BeamKernel::damped()
            } else {
                BeamKernel::elastic()
            };
            assert_eq!(k.damped, damped);
            let mut a = ElementState::new(&rest).unwrap();
            let mut b = a;
            let mut w = [Wrench::default(); 2];
            let turn = (k.run)(&sec, beta, &mut a, &moved, &mut w).unwrap();
            let mut out = ElementForce::default();
            internal_force(&sec, &mut b, &moved, &mut out).unwrap();
            assert_eq!(a, b);
            assert_eq!(turn, out.d_kappa.norm() * out.length);
            let mut expect = out.wrench;
            if damped {
                let (gd, kd) = crate::kernels::beam_element::strain_rate(&moved).unwrap();
                let s = crate::kernels::beam_element::section_rotations(&moved, &out.frame);
                let d = crate::kernels::beam_element::nodal_wrenches(
                    &out.frame,
                    out.length,
                    &s,
                    &(sec.c_gamma().component_mul(&gd) * beta),
                    &(sec.c_kappa().component_mul(&kd) * beta),
                );
                assert!(d[0].f.norm() > 0.0, "the damping forces are not zero here");
                for i in 0..2 {
                    expect[i].f += d[i].f;
                    expect[i].t += d[i].t;
                }
            }
            for i in 0..2 {
                assert_eq!(w[i].f, expect[i].f, "{damped} node {i}");
                assert_eq!(w[i].t, expect[i].t, "{damped} node {i}");
            }
        }
    }
}
