//! The quasi-static pushing simulator (section II-A and III of the paper): a convex part on a
//! three-point support, pushed by a probe disc along piecewise-linear paths, touching fixture
//! walls, advanced by solving the 2.5D mixed LCP of Eq. 7–8 at every step of probe travel; the
//! plans it replays ([`plan`]) and the effects beyond the nominal model ([`effects`]).
//!
//! May depend on: `mesopush-core`, `mesopush-lcp`, `mesopush-protocol` (unit conversions).
//! Never on vision, trial logs, the rig or anything above them.

pub mod advance;
pub mod cone;
pub mod contact;
pub mod coulomb;
pub mod effects;
pub mod error;
pub mod fixture;
pub mod formulate;
pub mod model;
pub mod needle;
pub mod pusher;
pub mod settings;
pub mod support;
pub mod support_set;

pub use error::Error;
pub use fixture::Fixture;
pub use model::{Model, Part};
pub use needle::Overload;
pub use pusher::{Disc, Pusher};
pub use settings::{SimSettings, SupportFriction};
pub use support::SupportDistribution;
pub mod path;
pub mod plan;
pub mod replay;
pub mod start;
pub mod stepper;
pub mod trajectory;

pub use path::{PathReplay, PathSample, ProbePoint, follow_path};
pub use plan::Plan;
pub use replay::{Replay, replay};
pub use stepper::{SimState, Simulator};
