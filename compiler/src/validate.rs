//! Checks of a lowered scene that need no simulation: joints satisfied by the initial
//! state, redundant constraints, bodies not connected to ground.

use mbdc_runtime::scene::Scene;

use crate::diag::{codes, Diagnostic};
use crate::kinematics;
use crate::source::Sources;
use crate::summary::free_bodies;

/// Position (m or rad) and velocity (m/s or rad/s) residuals above which a joint is
/// reported as violated at t = 0.
pub const VIOLATION_TOLERANCE: f64 = 1e-6;

/// Diagnostics (warnings and notes) about a valid scene.
pub fn validate(scene: &Scene, sources: &Sources) -> Vec<Diagnostic> {
    let mut out = Vec::new();
    let Some(check) = kinematics::initial_check(scene) else {
        return out;
    };
    for (j, (p, v)) in scene.joints.iter().zip(&check.violations) {
        let (p, v) = (*p, *v);
        let (file, span) = Sources::resolve(j.origin);
        if p > VIOLATION_TOLERANCE {
            out.push(
                Diagnostic::warning(
                    codes::INITIAL_VIOLATION,
                    format!("joint `{}` is violated by {p:.3e} at t = 0", j.name),
                )
                .primary(
                    file,
                    span,
                    "the initial positions do not satisfy this joint",
                )
                .help("move the bodies onto the constraint, or run with `mbdc run --assemble`"),
            );
        } else if v > VIOLATION_TOLERANCE {
            out.push(
                Diagnostic::warning(
                    codes::INITIAL_VIOLATION,
                    format!("the initial velocities violate joint `{}` by {v:.3e}", j.name),
                )
                .primary(file, span, "velocities not consistent with this joint")
                .help("give velocities that satisfy the constraint (the joint points must move together), or run with `mbdc run --assemble`"),
            );
        }
    }
    let (rank, rows) = check.rank;
    if rank < rows {
        let mut d = Diagnostic::warning(
            codes::DOF,
            format!(
                "the joints have {} redundant constraint row{} at t = 0 (Jacobian rank {rank} of {rows} rows): {}",
                rows - rank,
                if rows - rank == 1 { "" } else { "s" },
                check.redundant.join("; ")
            ),
        )
        .help("redundant rows are fine for staggered and natural_partitioning (they regularize them) and for implicit_trapezoid (it sets them aside), but make baumgarte and coordinate_partitioning fail; planar mechanisms modelled with 3-D revolute joints are redundant, spherical or universal joints remove the extra rows");
        if let Some(j) = scene.joints.first() {
            let (f, s) = Sources::resolve(j.origin);
            d = d.primary(f, s, "");
        }
        out.push(d);
    }
    let free = free_bodies(scene);
    if !free.is_empty() {
        let names: Vec<String> = free
            .iter()
            .map(|&i| format!("`{}`", scene.bodies[i].name))
            .collect();
        let shown = if names.len() > 10 {
            format!("{}, … ({} in all)", names[..10].join(", "), names.len())
        } else {
            names.join(", ")
        };
        let mut d = Diagnostic::note(
            codes::FREE_BODIES,
            format!(
                "{} not connected to ground: {shown}",
                if free.len() == 1 {
                    "this body is"
                } else {
                    "these bodies are"
                }
            ),
        );
        for &i in free.iter().take(10) {
            let (f, s) = head(scene.bodies[i].origin, sources);
            d = d.secondary(f, s, "free");
        }
        out.push(d.help("free bodies move under their forces alone; that is fine if intended"));
    }
    out
}

/// The span of a declaration's head (`body ball`), up to its block or value.
fn head(o: mbdc_runtime::scene::Origin, sources: &Sources) -> (crate::FileId, mbdc_dsl::ast::Span) {
    let (f, s) = Sources::resolve(o);
    let text = sources.snippet(o);
    let cut = text.find(['{', '=', '\n']).unwrap_or(text.len());
    let end = s.start + text[..cut].trim_end().len();
    (f, mbdc_dsl::ast::Span::new(s.start, end.max(s.start)))
}
