//! PRELU as one tract operator: `y = x` where `x > 0`, else `alpha[c] · x`, with the slopes
//! broadcast along the last (channel) axis.
//!
//! Built from tract's element-wise ops PRELU needs four (`max`, `min`, `mul`, `add`), which
//! tract fuses into two passes on most layers and three on the largest; this is one pass,
//! vectorised over contiguous channels.

use tract_core::internal::*;

/// Channel-wise PRELU on f32 tensors whose last axis has `alpha.len()` channels.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct ChannelPrelu {
    /// Slopes `[C]`.
    pub alpha: Arc<Tensor>,
}

impl Op for ChannelPrelu {
    fn name(&self) -> StaticName {
        "MonohandChannelPrelu".into()
    }

    op_as_typed_op!();
}

impl EvalOp for ChannelPrelu {
    op_out_of_plan!();

    fn eval(&self, _ctx: &EvalContext, inputs: TVec<TValue>) -> TractResult<TVec<TValue>> {
        let input = args_1!(inputs);
        let mut x = input.into_tensor();
        {
            let a = self.alpha.try_as_plain_ram()?;
            let a = a.as_slice::<f32>()?;
            let mut v = x.try_as_plain_ram_mut()?;
            let v = v.as_slice_mut::<f32>()?;
            ensure!(
                !a.is_empty() && v.len() % a.len() == 0,
                "PRELU slopes do not divide the tensor"
            );
            apply(v, a);
        }
        Ok(tvec!(x.into_tvalue()))
    }
}

impl TypedOp for ChannelPrelu {
    as_op!();

    fn output_facts(&self, inputs: &[&TypedFact]) -> TractResult<TVec<TypedFact>> {
        let last = inputs[0].shape.last().context("PRELU on a scalar")?;
        ensure!(
            last.to_usize().ok() == Some(self.alpha.len()),
            "PRELU: {} slopes for a last axis of {last}",
            self.alpha.len()
        );
        Ok(tvec!(inputs[0].without_value()))
    }
}

fn apply(v: &mut [f32], a: &[f32]) {
    for row in v.chunks_exact_mut(a.len()) {
        for (x, &a) in row.iter_mut().zip(a) {
            let neg = x.min(0.0);
            *x = x.max(0.0) + a * neg;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn negative_values_are_scaled_per_channel() {
        let op = ChannelPrelu {
            alpha: tensor1(&[0.5f32, -2.0]).into_arc_tensor(),
        };
        let x = Tensor::from_shape(&[1, 2, 2], &[1.0f32, -1.0, -4.0, 3.0]).expect("x");
        let y = op
            .eval_out_of_plan(tvec!(x.into_tvalue()))
            .expect("eval")
            .expect("out of plan");
        let y = y[0].try_as_plain_ram().expect("ram");
        assert_eq!(y.as_slice::<f32>().expect("f32"), &[1.0, 2.0, -2.0, 3.0]);
    }
}
