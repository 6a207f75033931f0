//! Floor 1, the kernels: pure functions that evaluate one element of a scene at one
//! configuration, into caller-owned buffers. They know the contract (floor 0) and nothing
//! above it: no integrator, no solver, no writer.
//!
//! - [`beam_element`]: the flexible-beam element's internal force (co-rotational,
//!   incremental, shear-deformable; notes B §6.4), its strain rates and lumped mass.
//! - [`joints`]: the constraint rows of every joint kind (value, Jacobian, velocity and
//!   acceleration terms).
//! - [`tree_joints`]: the null-space blocks of tree joints (`u_c = X u_p + S q̇`) and their
//!   position projection, for natural partitioning.
//! - [`forces`]: applied forces (gravity, springs, dampers, actuators) and their energy.
//! - [`contact`]: penalty contact laws (sphere–plane, sphere–sphere, box–plane).
//! - [`fn1`]: time functions (`f(t)` trees) with their first two derivatives.
//! - [`solid`]: solid finite elements (bar2, tri3, quad4, tet4, hex8; small strain or total
//!   Lagrangian St Venant–Kirchhoff; one-point hex8/quad4 with Flanagan–Belytschko hourglass
//!   control or full integration with B-bar): internal force, stress, lumped mass, element
//!   frequency bound and shape check.
//!
//! - [`traction_basis`]: the interface traction bases of reduced Lagrange multipliers
//!   (global polynomials, piecewise cubics with Bessel slopes) and their edge integrals.
//!
//! Where new element kernels go: an element's internal force is a kernel here, as the beam
//! element's ([`beam_element`]) and the solid elements' ([`solid`]) are.

pub mod beam_element;
pub mod contact;
pub mod fn1;
pub mod forces;
pub mod joints;
pub mod solid;
pub mod traction_basis;
pub mod tree_joints;
