//! The JavaScript class over [`Tracker`] (used in the WebAssembly build only; it compiles natively for the lints). Records and notes cross
//! as JSON text, written by the same code as `monohand run`'s lines; `web/monohand.js`
//! parses them into plain objects.

use crate::mesh::HandMeshes;
use crate::{records_json, Tracker, TrackerOptions, WebError};
use monohand_core::hand_model::{HandSide, NUM_JOINTS};
use monohand_io::jsonl::FrameRecord;
use wasm_bindgen::prelude::*;

fn js_error(e: WebError) -> JsError {
    JsError::new(&e.to_string())
}

/// `sharedOperators()` for JavaScript: how many operator evaluations this module has shared
/// between threads so far (the operator team, `startOperatorTeam`; always 0 in the
/// one-thread module).
#[wasm_bindgen(js_name = sharedOperators)]
pub fn shared_operators() -> usize {
    monohand_vision::tflite_import::shared_operators()
}

/// A tracking session in the page (see [`Tracker`]).
#[wasm_bindgen]
pub struct WebTracker {
    inner: Tracker,
}

#[wasm_bindgen]
impl WebTracker {
    /// Loads the networks from the bytes of MediaPipe's palm detector and hand landmark
    /// `.tflite` files; `options` is JSON ([`TrackerOptions`]; empty for the defaults).
    #[wasm_bindgen(constructor)]
    pub fn new(palm: &[u8], landmark: &[u8], options: &str) -> Result<WebTracker, JsError> {
        let options = TrackerOptions::from_json(options).map_err(js_error)?;
        let inner = Tracker::new(palm, landmark, options).map_err(js_error)?;
        Ok(WebTracker { inner })
    }

    /// One RGBA frame (`ImageData.data`) of `width` x `height` at `time_s` seconds; returns
    /// the records of the frames now done, as a JSON array.
    pub fn process(
        &mut self,
        rgba: &[u8],
        width: u32,
        height: u32,
        time_s: f64,
    ) -> Result<String, JsError> {
        let records = self
            .inner
            .process_rgba(rgba, width, height, time_s)
            .map_err(js_error)?;
        records_json(&records).map_err(js_error)
    }

    /// The records of the frames still kept back, as a JSON array (call at the end).
    pub fn finish(&mut self) -> Result<String, JsError> {
        records_json(&self.inner.finish()).map_err(js_error)
    }

    /// Messages for the user since the last call, as a JSON array of strings.
    pub fn notes(&mut self) -> String {
        let notes = self.inner.take_notes();
        serde_json::to_string(&notes).unwrap_or_else(|_| "[]".into())
    }
}

/// The skinned hand for the page's 3D view (see [`HandMeshes`]).
#[wasm_bindgen]
pub struct WebHandMesh {
    inner: HandMeshes,
}

#[wasm_bindgen]
impl WebHandMesh {
    /// Parses the left and right meshes.
    #[wasm_bindgen(constructor)]
    pub fn new() -> Result<WebHandMesh, JsError> {
        Ok(WebHandMesh {
            inner: HandMeshes::new().map_err(js_error)?,
        })
    }

    /// A binary glTF of a record's (JSON) fitted hands as skinned meshes.
    pub fn glb(&self, record: &str) -> Result<Vec<u8>, JsError> {
        let frame: FrameRecord =
            serde_json::from_str(record).map_err(|e| JsError::new(&format!("bad record: {e}")))?;
        HandMeshes::glb(&frame).map_err(js_error)
    }

    /// The 25 mesh joints' poses (8 numbers each) for `side` ("left" or "right") and the 63
    /// numbers of a record's `joints_3d_mm`; empty if the palm is degenerate.
    pub fn pose(&self, side: &str, joints_mm: &[f64]) -> Result<Vec<f32>, JsError> {
        let side = match side {
            "left" => HandSide::Left,
            "right" => HandSide::Right,
            other => return Err(JsError::new(&format!("bad side {other:?}: left or right"))),
        };
        if joints_mm.len() != 3 * NUM_JOINTS {
            return Err(JsError::new(&format!(
                "{} numbers for the joints, not {}",
                joints_mm.len(),
                3 * NUM_JOINTS
            )));
        }
        let joints: [[f64; 3]; NUM_JOINTS] =
            std::array::from_fn(|j| [joints_mm[3 * j], joints_mm[3 * j + 1], joints_mm[3 * j + 2]]);
        Ok(self.inner.pose(side, &joints).unwrap_or_default())
    }
}
