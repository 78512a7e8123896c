//! Microscope vision (paper §IV): the only sensing the system has. A synthetic microscope
//! renders frames of the fixture, peg and probe with ground truth; the tracker measures the
//! peg's pose and the probe tip from frames by background subtraction, thresholding, probe
//! removal by its geometry and an ellipse fit to the peg's second moments.
//!
//! May depend on: `mesopush-core` (geometry), `mesopush-framestore` (frames on disk) and
//! `mesopush-capture` (camera frames, shared with the executor) only. It knows images,
//! optics and outlines, not the simulator, trial logs or the rig: callers hand it polygons
//! and poses.

pub mod assess;
pub mod background;
pub mod calib;
pub mod calib_fit;
pub mod capture;
pub mod demo;
pub mod error;
pub mod folder;
pub mod frame_source;
pub mod moments;
pub mod morph;
pub mod needle;
pub(crate) mod optics;
pub mod overlay;
pub mod probe;
pub(crate) mod raster;
pub mod render;
pub mod scale_lock;
pub mod scene;
pub mod threshold;
pub mod tip;
pub mod track;
pub(crate) mod weigh;

pub use assess::{Flag, Measurement};
pub use background::Background;
pub use calib::Calibration;
pub use error::Error;
pub use frame_source::{FrameSet, TrialFrames};
pub use needle::NeedleSettings;
pub use probe::ProbeSettings;
pub use render::{GroundTruth, RenderSettings, Rendered, Renderer, render};
pub use scale_lock::ScaleLearning;
pub use scene::{DemoFixture, Scene, paper_peg};
pub use threshold::Threshold;
pub use tip::TipFlag;
pub use track::{TrackSettings, Tracker};
