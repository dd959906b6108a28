//! The JavaScript class over [`Tracker`] (WebAssembly build only). Records and notes cross
//! as JSON text, written by the same code as `monohand run`'s lines; `web/monohand.js`
//! parses them into plain objects.

use crate::{records_json, Tracker, TrackerOptions, WebError};
use wasm_bindgen::prelude::*;

fn js_error(e: WebError) -> JsError {
    JsError::new(&e.to_string())
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
