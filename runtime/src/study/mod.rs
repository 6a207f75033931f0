//! # Accuracy studies: what accuracy costs
//!
//! **What it is.** The work–precision engine behind `mbdc sweep`: run a scene over a series
//! of step sizes and methods, measure each run's CPU time and its error against a reference,
//! and fit each method's convergence order.
//!
//! - **Plan** ([`Study::new`]): the duration, the [steps](step_series) (given, or halving
//!   from h_max = T_min/20 of the scene's [stability estimate](crate::analysis::step_limits)), and the
//!   [methods] (given, or every method that can start on the scene).
//! - **Run** ([`Study::run`]): every (method, step) through a [`Runner`] — the
//!   [`InterpRunner`] here, or any other (`mbdc sweep` runs the compiled program) — repeated
//!   until the repetitions add up to [`StudyOptions::min_time`] of CPU time, the best kept.
//!   Runs that diverge or stop stay in the results with their [`Status`].
//! - **Reference**: the scene's `reference { … }` ([`Analytic`] functions or a [`Table`]),
//!   or a [numerical reference](numerical_reference) run with its Richardson error estimate
//!   e(h_ref) ≈ |y(2h_ref) − y(h_ref)| / (2^p − 1).
//! - **Errors** ([`error_measures`]): RMS over bodies of the position error and of the
//!   rotation angle, at the final time and the largest over the frames.
//! - **Order** ([`fit`]): the least-squares slope of log(error) on log(h) over the
//!   converging range, with the runs left out and why, [flagged](fit::flagged) when it
//!   differs from the theoretical order by more than 0.3; and [what an error costs](cost).
//!
//! **What it must never know.** Terminals, files it was not asked to read (only a scene's
//! reference table), command-line arguments, plotting. It prints nothing: progress goes to
//! a [`Progress`] receiver, results are data ([`StudyResult`]), failures are
//! [`StudyError`]s.
//!
//! **How to use it.** Build a [`Scene`](crate::contract::scene::Scene) (or load one with
//! `mbdc-compiler`), set [`StudyOptions`], and call [`run_study`] with a runner; or plan with
//! [`Study::new`], look at the plan, and [`Study::run`] it with a [`Progress`] receiver.
//!
//! ```
//! use mbdc_runtime::scene::*;
//! use mbdc_runtime::study::{run_study, InterpRunner, StudyOptions};
//!
//! // A 1 kg mass on a 100 N/m spring, released 0.1 m from rest: x(t) = 0.1 cos(10 t).
//! let at = |body, point| Attachment { body, point, frame: [1.0, 0.0, 0.0, 0.0] };
//! let f = |x: Fn1| Box::new(x);
//! let x_exact = Fn1::Mul(
//!     f(Fn1::Const(0.1)),
//!     f(Fn1::Unary(UnaryFn::Cos, f(Fn1::Mul(f(Fn1::Const(10.0)), f(Fn1::Var))))),
//! );
//! let scene = Scene {
//!     name: "oscillator".into(),
//!     gravity: None,
//!     bodies: vec![Body {
//!         name: "m".into(),
//!         mass: 1.0,
//!         inertia: [[0.01, 0.0, 0.0], [0.0, 0.01, 0.0], [0.0, 0.0, 0.01]],
//!         position: [0.1, 0.0, 0.0],
//!         orientation: [1.0, 0.0, 0.0, 0.0],
//!         velocity: [0.0; 3],
//!         angular_velocity: [0.0; 3],
//!         origin: Origin::default(),
//!     }],
//!     joints: vec![],
//!     forces: vec![Force {
//!         name: "k".into(),
//!         kind: ForceKind::Spring {
//!             a: at(BodyRef::Ground, [-1.0, 0.0, 0.0]),
//!             b: at(BodyRef::Body(0), [0.0; 3]),
//!             stiffness: 100.0,
//!             rest_length: 1.0,
//!             damping: 0.0,
//!         },
//!         origin: Origin::default(),
//!     }],
//!     beams: vec![],
//!     meshes: vec![],
//!     contacts: vec![],
//!     simulate: Simulate::default(),
//!     reference: Some(Reference {
//!         bodies: vec![BodyReference {
//!             body: 0,
//!             position: Some([x_exact, Fn1::Const(0.0), Fn1::Const(0.0)]),
//!             orientation: None,
//!         }],
//!         table: None,
//!     }),
//!     params: vec![],
//! };
//! let options = StudyOptions {
//!     methods: vec!["staggered".into()],
//!     levels: 4,
//!     min_time: 0.0, // one run per step: no timing repetitions
//!     ..StudyOptions::default()
//! };
//! let mut runner = InterpRunner::new(&scene)?;
//! let result = run_study(&scene, &options, &mut runner)?;
//! // steps halve from T/20 = 2π/(20·10 rad/s), shrunk to 32 steps in the 1 s
//! assert_eq!(result.runs.len(), 4);
//! assert!((result.runs[0].step - 1.0 / 32.0).abs() < 1e-12);
//! let order = result.fit_of("staggered").and_then(|f| f.order).expect("an order");
//! assert!((order - 2.0).abs() < 0.1, "{order}");
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod analytic;
pub mod cost;
pub mod cpu_time;
pub mod engine;
pub mod error;
pub mod error_measures;
pub mod fit;
pub mod interp_runner;
pub mod methods;
pub mod numerical_reference;
pub mod options;
pub mod progress;
pub mod reference;
pub mod result;
pub mod runner;
pub mod sampled;
pub mod step_series;
pub mod table;
pub mod track;

pub use analytic::Analytic;
pub use cost::Cost;
pub use cpu_time::thread_cpu_time;
pub use engine::{run_study, Study};
pub use error::{ReferenceError, RunnerError, StudyError};
pub use error_measures::{measure, rotation_angle, Errors, Measure};
pub use fit::{Excluded, Fit};
pub use interp_runner::InterpRunner;
pub use methods::{theoretical_order, MethodEntry};
pub use options::{StudyOptions, MAX_LEVELS};
pub use progress::Progress;
pub use reference::{RefBody, RefSolution};
pub use result::{ReferenceInfo, StudyResult, StudyRun};
pub use runner::{Outcome, Request, Runner, Status};
pub use sampled::{Sampled, Sampler};
pub use step_series::FastestRate;
pub use table::Table;
pub use track::Track;
