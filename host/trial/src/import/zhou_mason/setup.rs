//! The four set-ups of the Zhou & Mason 2017 logs: which object each pushed, its outline in
//! the logged object frame, the support, and the registration tolerance found for it
//! (`docs/import-zhou-mason.md` gives the evidence for every number here).

use crate::Error;

/// Finger radius of the two-finger hand, mm (the authors' planning scripts).
pub const FINGER_RADIUS_MM: f64 = 2.5;
/// Distance between the two finger centres, mm. The scripts say 18 or 24; the data cannot
/// separate them on flat faces, and on the triangle's 27.5 mm leg 24 mm would put a finger
/// past the vertex (docs/import-zhou-mason.md), so 18 (the value of the final scripts).
pub const FINGER_SPACING_MM: f64 = 18.0;
/// Rectangle size, mm (the real part; the planners' 51 × 36 outline adds a 0.5 mm buffer).
pub const RECT_MM: [f64; 2] = [50.0, 35.0];
/// Triangle legs L (along x) and S (along y), mm; right angle at (L/3, −S/3).
pub const TRI_LEGS_MM: [f64; 2] = [58.0, 27.5];
/// Butterfly: the lines its four pushed faces lie on in the logged object frame, mm
/// (x_min, x_max, y_min, y_max): the median finger-midpoint position in contact on each face
/// over all 15 runs, less the finger radius. The true (non-convex) outline is not published
/// with the data; this box is what the pushes touch, not the shape.
pub const BUTTER_FACES_MM: [f64; 4] = [-11.0, 15.7, -16.2, 19.8];

/// One set-up (the top folder of the data).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SetUp {
    /// The rectangle on three support points.
    BigRect3Pts,
    /// The rectangle on a ridge.
    BigRectRidge,
    /// The right triangle on its face.
    Tri,
    /// The butterfly on its face.
    Butter,
}

impl SetUp {
    /// Every set-up, longest folder name first (so prefixes match unambiguously).
    pub const ALL: [SetUp; 4] =
        [SetUp::BigRect3Pts, SetUp::BigRectRidge, SetUp::Butter, SetUp::Tri];

    /// The folder name.
    pub fn name(self) -> &'static str {
        match self {
            SetUp::BigRect3Pts => "bigrect_3pts",
            SetUp::BigRectRidge => "bigrect_ridge",
            SetUp::Tri => "tri",
            SetUp::Butter => "butter",
        }
    }

    /// Splits a start folder's name (`<set-up>_<x>_<y>_<θ>`) into its set-up and start.
    pub fn parse_start_folder(folder: &str) -> Result<(SetUp, String), Error> {
        SetUp::ALL
            .iter()
            .find_map(|s| {
                let start = folder.strip_prefix(s.name())?.strip_prefix('_')?;
                (!start.is_empty()).then(|| (*s, start.to_string()))
            })
            .ok_or_else(|| {
                Error::invalid(
                    "zhou-mason start folder",
                    format!(
                        "{folder:?} is not <set-up>_<start>; set-ups: {}",
                        SetUp::ALL.map(SetUp::name).join(", ")
                    ),
                )
            })
    }

    /// The object's outline in the logged object frame (the point and axes the log's
    /// `obj_*` columns give), mm, counter-clockwise.
    pub fn outline_mm(self) -> Vec<[f64; 2]> {
        match self {
            SetUp::BigRect3Pts | SetUp::BigRectRidge => {
                let [hx, hy] = RECT_MM.map(|v| v / 2.0);
                vec![[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy]]
            }
            SetUp::Tri => {
                let [l, s] = TRI_LEGS_MM;
                vec![[l / 3.0, -s / 3.0], [l / 3.0, 2.0 * s / 3.0], [-2.0 * l / 3.0, -s / 3.0]]
            }
            SetUp::Butter => {
                let [x0, x1, y0, y1] = BUTTER_FACES_MM;
                vec![[x0, y0], [x1, y0], [x1, y1], [x0, y1]]
            }
        }
    }

    /// The object's COM in the logged object frame, mm: the logged point itself for the
    /// rectangle (its centre) and the triangle (its centroid); the box centre for the
    /// butterfly (the centre of symmetry of its opposite pushes).
    pub fn com_mm(self) -> [f64; 2] {
        match self {
            SetUp::BigRect3Pts | SetUp::BigRectRidge | SetUp::Tri => [0.0, 0.0],
            SetUp::Butter => {
                let [x0, x1, y0, y1] = BUTTER_FACES_MM;
                [(x0 + x1) / 2.0, (y0 + y1) / 2.0]
            }
        }
    }

    /// Where the outline comes from, for the trial's `import` note.
    pub fn outline_source(self) -> &'static str {
        match self {
            SetUp::BigRect3Pts | SetUp::BigRectRidge => {
                "rectangle 50 x 35 mm centred on the logged point, 50 mm side along the object's x \
                 (data README; axes and centre confirmed from the contacts)"
            }
            SetUp::Tri => {
                "right triangle, legs 58 mm (x) and 27.5 mm (y), vertices (L/3, -S/3), (L/3, \
                 2S/3), (-2L/3, -S/3): centroid at the logged point (authors' scripts)"
            }
            SetUp::Butter => {
                "ESTIMATED: the butterfly is not convex and its outline is not published with the \
                 data; this is the box of the four faces its pushes touch (median finger contact \
                 over all butter runs, less the finger radius), COM taken at the box centre"
            }
        }
    }

    /// What the object rested on.
    pub fn support(self) -> &'static str {
        match self {
            SetUp::BigRect3Pts => "three support points",
            SetUp::BigRectRidge => "a ridge",
            SetUp::Tri | SetUp::Butter => "its face",
        }
    }

    /// How deep a finger may appear inside the part through registration error alone, mm
    /// (the deepest contact penetration measured, rounded up; butterfly: not measurable).
    pub fn registration_tolerance_mm(self) -> f64 {
        match self {
            SetUp::BigRect3Pts | SetUp::BigRectRidge => 3.5,
            SetUp::Tri => 4.0,
            SetUp::Butter => 4.5,
        }
    }
}
