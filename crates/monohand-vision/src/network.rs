//! A network imported from `.tflite`, optimised and ready to run on f32 NHWC tensors.

use std::path::Path;

use tract_core::internal::*;

use crate::error::{Result, VisionError};
use monohand_tflite as tflite_import;

/// An optimised tract plan for one TFLite network with a single NHWC f32 input.
#[derive(Debug, Clone)]
pub struct TfliteNet {
    plan: Arc<TypedSimplePlan>,
    input_shape: [usize; 4],
}

impl TfliteNet {
    /// Imports, optimises and prepares `bytes` (a `.tflite` flatbuffer). `origin` names the
    /// model in errors.
    pub fn from_bytes(bytes: &[u8], origin: &Path) -> Result<Self> {
        Self::from_bytes_with(bytes, origin, tflite_import::ImportOptions::default())
    }

    /// [`from_bytes`](Self::from_bytes) with explicit importer options (e.g. tract's own
    /// operators instead of monohand's, to compare).
    pub fn from_bytes_with(
        bytes: &[u8],
        origin: &Path,
        options: tflite_import::ImportOptions,
    ) -> Result<Self> {
        let model =
            tflite_import::import_with(bytes, options).map_err(|source| VisionError::Import {
                path: origin.into(),
                source,
            })?;
        let fact = model.input_fact(0)?.clone();
        let shape = fact
            .shape
            .as_concrete()
            .filter(|s| s.len() == 4)
            .map(|s| [s[0], s[1], s[2], s[3]])
            .ok_or_else(|| {
                VisionError::ModelOutput(format!(
                    "{}: input is not a 4D NHWC tensor",
                    origin.display()
                ))
            })?;
        let plan = model.into_optimized()?.into_runnable()?;
        Ok(TfliteNet {
            plan,
            input_shape: shape,
        })
    }

    /// Input shape `[1, height, width, channels]`.
    pub fn input_shape(&self) -> [usize; 4] {
        self.input_shape
    }

    /// A zeroed input tensor of the right shape.
    pub fn input_tensor(&self) -> Result<Tensor> {
        Ok(Tensor::zero::<f32>(&self.input_shape)?)
    }

    /// An input tensor whose `h x w x c` f32 buffer is written in place by `fill`.
    pub fn input_with(&self, fill: impl FnOnce(&mut [f32])) -> Result<Tensor> {
        let mut t = self.input_tensor()?;
        {
            let mut view = t.try_as_plain_ram_mut()?;
            fill(view.as_slice_mut::<f32>()?);
        }
        Ok(t)
    }

    /// Runs the network; returns each output flattened to f32.
    pub fn run(&self, input: Tensor) -> Result<Vec<Vec<f32>>> {
        if input.shape() != self.input_shape {
            return Err(VisionError::Inference(format!(
                "input shape {:?}, network expects {:?}",
                input.shape(),
                self.input_shape
            )));
        }
        let outputs = self.plan.run(tvec!(input.into_tvalue()))?;
        outputs
            .iter()
            .map(|o| {
                Ok(o.cast_to::<f32>()?
                    .try_as_plain_ram()?
                    .as_slice::<f32>()?
                    .to_vec())
            })
            .collect()
    }
}
