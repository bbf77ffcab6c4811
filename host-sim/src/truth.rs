//! The JSON contract shared by `truth.json` and `vorl detect --json` (DESIGN.md, "Contracts").

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

/// `{"frames": {"<name>.png": [part, …]}}`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct FramesJson {
    /// Parts per frame file name, in name order.
    pub frames: BTreeMap<String, Vec<PartJson>>,
}

/// One part, as truth or prediction. Unknown fields are kept (`extra`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PartJson {
    /// Template class, `null` for a part that is not a template (or not recognised).
    pub class: Option<String>,
    /// Area centroid x, px.
    pub x: f64,
    /// Area centroid y, px.
    pub y: f64,
    /// Rotation, degrees counter-clockwise on screen, [0, 360).
    pub angle_deg: f64,
    /// n-fold rotational symmetry (truth; 0 = angle undefined).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub symmetry: Option<u32>,
    /// f' of the match (prediction).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub score: Option<f64>,
    /// Cut by the frame border.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub partial: Option<bool>,
    /// Lying upside down: the template mirrored left-right about its centroid, then turned by
    /// `angle_deg` (DESIGN.md).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub flipped: Option<bool>,
    /// Found in, or drawn as part of, a blob that holds other parts too: against or partly
    /// over another part.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub touching: Option<bool>,
    /// Any other fields.
    #[serde(flatten)]
    pub extra: BTreeMap<String, serde_json::Value>,
}

impl FramesJson {
    /// Reads a truth or prediction file.
    ///
    /// # Errors
    /// A one-line message naming the file: missing, unreadable, or not of this shape.
    pub fn load(path: &Path) -> Result<Self, String> {
        let text =
            std::fs::read_to_string(path).map_err(|e| format!("{}: {}", path.display(), crate::io::io_problem(&e)))?;
        serde_json::from_str(&text).map_err(|e| format!("{}: does not parse as truth JSON: {e}", path.display()))
    }
}
