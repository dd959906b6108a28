//! What the f32 and the int8 1x1 convolutions ([`crate::PointwiseConv`],
//! [`crate::PointwiseConvInt8`]) share: the width of their weight panels ([`NR`]), the fused
//! [`Activation`], and the evaluation of a 1x1 convolution over channels-last tensors. Below
//! both: the f32 operator turns itself into the int8 one, which must not import it back.

use tract_core::internal::*;

/// Output channels per packed weight panel (two AVX2 vectors of 8 floats).
pub const NR: usize = 16;

/// An activation clamped into the result of a [`PointwiseConv`](crate::PointwiseConv) (TFLite's
/// fused activations).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub enum Activation {
    /// Identity.
    #[default]
    None,
    /// `max(x, 0)`.
    Relu,
    /// `min(max(x, 0), 6)`.
    Relu6,
}

impl Activation {
    /// The clamp bounds `(low, high)` the activation amounts to.
    pub(crate) fn bounds(self) -> (f32, f32) {
        match self {
            Activation::None => (f32::NEG_INFINITY, f32::INFINITY),
            Activation::Relu => (0.0, f32::INFINITY),
            Activation::Relu6 => (0.0, 6.0),
        }
    }
}

/// The `eval` of a 1x1 convolution over channels-last tensors ([`crate::PointwiseConv`]'s and
/// [`crate::PointwiseConvInt8`]'s; input `X` f32, or u8 codes for a coded
/// [`crate::PointwiseConvInt8`]; output f32): checks the inputs (`cin` channels, a residual of the
/// output's shape when `has_residual`), makes the output (`cout` channels) and has
/// `compute(input, residual, output)` write every one of its values.
pub(crate) fn eval_1x1<X: Datum>(
    inputs: &TVec<TValue>,
    cin: usize,
    cout: usize,
    has_residual: bool,
    what: &str,
    compute: impl FnOnce(&[X], Option<&[f32]>, &mut [f32]) -> TractResult<()>,
) -> TractResult<TVec<TValue>> {
    ensure!(
        inputs.len() == 1 + has_residual as usize,
        "{what} got {} inputs",
        inputs.len()
    );
    let x = &inputs[0];
    let mut shape: TVec<usize> = x.shape().into();
    ensure!(
        shape.last() == Some(&cin),
        "{what} over {cin} channels, input {shape:?}"
    );
    if let Some(last) = shape.last_mut() {
        *last = cout;
    }
    if let Some(r) = inputs.get(1) {
        ensure!(
            r.shape() == &*shape,
            "residual {:?} for an output {shape:?}",
            r.shape()
        );
    }
    // SAFETY: the tensor's values are left unwritten, and nothing reads one before it is
    // written: `compute` (each operator's) stores every output value from its epilogue (the
    // tiles cover all rows and channels, and only store into the output), and an error
    // drops the tensor without reading it (f32 has no drop).
    let mut output = unsafe { Tensor::uninitialized::<f32>(&shape)? };
    {
        let xr = x.try_as_plain_ram()?;
        let rr = inputs.get(1).map(|r| r.try_as_plain_ram()).transpose()?;
        let mut o = output.try_as_plain_ram_mut()?;
        compute(
            xr.as_slice::<X>()?,
            rr.as_ref().map(|r| r.as_slice::<f32>()).transpose()?,
            o.as_slice_mut::<f32>()?,
        )?;
    }
    Ok(tvec!(output.into_tvalue()))
}
