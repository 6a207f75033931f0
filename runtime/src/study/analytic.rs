//! The scene's analytic reference: `reference { body B { position …; orientation … } }`,
//! functions of time evaluated exactly at the frame times.

use crate::contract::scene::{BodyReference, Scene};
use crate::kernels::fn1;

use super::error::ReferenceError;
use super::reference::{RefBody, RefSolution};
use super::track::qnormalize;

/// The scene's analytic reference.
#[derive(Clone, Debug)]
pub struct Analytic {
    items: Vec<BodyReference>,
}

impl Analytic {
    /// From the scene's `reference` block (`None` if it has no body functions).
    pub fn new(scene: &Scene) -> Option<Analytic> {
        let r = scene.reference.as_ref()?;
        (!r.bodies.is_empty()).then(|| Analytic {
            items: r.bodies.clone(),
        })
    }
}

impl RefSolution for Analytic {
    fn at(&self, t: f64, out: &mut [RefBody]) -> Result<(), ReferenceError> {
        out.fill(RefBody::default());
        for it in &self.items {
            let slot = &mut out[it.body];
            if let Some(p) = &it.position {
                slot.r = Some([
                    fn1::value(&p[0], t),
                    fn1::value(&p[1], t),
                    fn1::value(&p[2], t),
                ]);
            }
            if let Some(q) = &it.orientation {
                let raw = [
                    fn1::value(&q[0], t),
                    fn1::value(&q[1], t),
                    fn1::value(&q[2], t),
                    fn1::value(&q[3], t),
                ];
                slot.q = Some(qnormalize(raw).ok_or(ReferenceError::NotARotation { t, q: raw })?);
            }
        }
        Ok(())
    }
}
