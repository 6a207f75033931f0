//! Natural partitioning (notes C §1): the null space of the spanning tree's constraint
//! Jacobian built joint by joint, the reduced equations solved through the arrowhead
//! system's Schur complement, and cut joints by staggered stabilization.

pub mod kin;
