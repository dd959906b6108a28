//! A network imported from `.tflite`, optimised and ready to run on f32 NHWC tensors.

use std::path::Path;
use std::sync::Mutex;

use tract_core::internal::*;

use crate::error::{Result, VisionError};
use monohand_tflite as tflite_import;

/// An optimised tract plan for one TFLite network with a single NHWC f32 input.
///
/// Besides the one-shot [`run`](Self::run), a network runs on reusable [`NetState`]s: tract's
/// run state and the input tensor are kept from call to call, the input is written in place
/// and the outputs are read as slices of tract's own output tensors (no copies). The
/// [`run_pooled`](Self::run_pooled) entry point keeps such states in a small pool shared by
/// the clones of a network, one per concurrent caller, so a network can be shared across
/// threads and still reuse its states.
#[derive(Debug, Clone)]
pub struct TfliteNet {
    plan: Arc<TypedSimplePlan>,
    /// Where each run's input is copied, when the network is [`recording`](Self::recording).
    recorder: Option<Arc<Mutex<Vec<Tensor>>>>,
    /// The arithmetic of its quantizable layers.
    precision: tflite_import::Precision,
    /// How many layers run in int8.
    int8_layers: usize,
    input_shape: [usize; 4],
    /// Idle run states, reused by [`Self::run_pooled`].
    pool: Arc<Mutex<Vec<NetState>>>,
}

/// One reusable run of a [`TfliteNet`]: tract's run state and the input tensor, kept across
/// calls (see [`TfliteNet::run_in`]). Made by [`TfliteNet::new_state`]; a state runs only the
/// network that made it.
#[derive(Debug)]
pub struct NetState {
    state: TypedSimpleState,
    /// The input tensor. The state holds a second reference only while a run is under way,
    /// so between runs this one is unique and is written in place.
    input: Arc<Tensor>,
}

impl NetState {
    /// The input tensor, as the last run left it (its buffer is reused by the next run).
    pub fn input(&self) -> &Tensor {
        &self.input
    }
}

/// The outputs of the last run of a [`NetState`], read in place.
#[derive(Debug, Clone, Copy)]
pub struct NetOutputs<'a> {
    state: &'a TypedSimpleState,
    count: usize,
}

impl<'a> NetOutputs<'a> {
    /// Number of outputs.
    pub fn len(&self) -> usize {
        self.count
    }

    /// Whether the network has no outputs.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// Output `i`, flattened (an error if it is not f32).
    pub fn get(&self, i: usize) -> Result<&'a [f32]> {
        let t: &'a Tensor = self.state.output(i)?;
        if t.datum_type() != f32::datum_type() {
            return Err(VisionError::Inference(format!(
                "output {i} is {:?}, not f32",
                t.datum_type()
            )));
        }
        Ok(t.try_as_plain_ram()?.as_slice::<f32>()?)
    }

    /// The first `N` outputs (an error if there are fewer).
    pub fn first<const N: usize>(&self) -> Result<[&'a [f32]; N]> {
        let mut out: [&'a [f32]; N] = [&[]; N];
        for (i, o) in out.iter_mut().enumerate() {
            *o = self.get(i)?;
        }
        Ok(out)
    }
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
        Self::from_bytes_in(bytes, origin, options, tflite_import::Precision::F32)
    }

    /// [`from_bytes_with`](Self::from_bytes_with) in `precision`: in int8, the layers the
    /// network's shipped calibration covers run in int8 ([`crate::int8::import`]).
    pub fn from_bytes_in(
        bytes: &[u8],
        origin: &Path,
        options: tflite_import::ImportOptions,
        precision: tflite_import::Precision,
    ) -> Result<Self> {
        let (model, int8_layers) = crate::int8_tables::import(bytes, origin, options, precision)?;
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
            recorder: None,
            precision,
            int8_layers,
            input_shape: shape,
            pool: Arc::new(Mutex::new(Vec::new())),
        })
    }

    /// The network, copying the input of each of its runs (its clones' too) into
    /// `recorder`: what an int8 calibration is measured on ([`crate::int8::calibrate`]).
    pub fn recording(mut self, recorder: Arc<Mutex<Vec<Tensor>>>) -> Self {
        self.recorder = Some(recorder);
        self
    }

    /// The arithmetic it was built in.
    pub fn precision(&self) -> tflite_import::Precision {
        self.precision
    }

    /// How many of its layers run in int8 (0 in f32).
    pub fn int8_layers(&self) -> usize {
        self.int8_layers
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

    /// A fresh run state for this network.
    pub fn new_state(&self) -> Result<NetState> {
        Ok(NetState {
            state: self.plan.spawn()?,
            input: Arc::new(self.input_tensor()?),
        })
    }

    /// Runs the network on `state`: `fill` writes the input in place (the `h x w x c` f32
    /// buffer, which still holds the previous call's input, so `fill` must write every value),
    /// then `read` gets the outputs. Nothing is allocated for the input or the outputs once
    /// the state has run; tract still allocates its intermediate tensors.
    pub fn run_in<R>(
        &self,
        state: &mut NetState,
        fill: impl FnOnce(&mut [f32]),
        read: impl FnOnce(NetOutputs<'_>) -> Result<R>,
    ) -> Result<R> {
        self.with_input(state, fill)?;
        self.exec(state, read)
    }

    /// Calls `f` on `state`'s own input buffer, to be written before [`exec`](Self::exec).
    fn with_input<T>(&self, state: &mut NetState, f: impl FnOnce(&mut [f32]) -> T) -> Result<T> {
        if !Arc::ptr_eq(state.state.plan(), &self.plan) {
            return Err(VisionError::Inference(
                "run state belongs to another network".into(),
            ));
        }
        if Arc::get_mut(&mut state.input).is_none() {
            // Something still holds the previous input (an operator kept it): start anew.
            state.input = Arc::new(self.input_tensor()?);
        }
        let input = Arc::get_mut(&mut state.input)
            .ok_or_else(|| VisionError::Inference("input tensor is shared".into()))?;
        let mut view = input.try_as_plain_ram_mut()?;
        Ok(f(view.as_slice_mut::<f32>()?))
    }

    /// Runs `state` on the input [`with_input`](Self::with_input) wrote, then `read` gets
    /// the outputs.
    fn exec<R>(
        &self,
        state: &mut NetState,
        read: impl FnOnce(NetOutputs<'_>) -> Result<R>,
    ) -> Result<R> {
        if let Some(r) = &self.recorder {
            r.lock()
                .map_err(|_| VisionError::Inference("input recorder poisoned".into()))?
                .push((*state.input).clone());
        }
        // Counted while it runs: alone, its operators share their rows between the cores.
        let _running = monohand_tflite::Running::start();
        state
            .state
            .set_input(0, TValue::from_const(Arc::clone(&state.input)))?;
        let out = match state.state.exec() {
            Ok(()) => read(NetOutputs {
                count: self.plan.model().outputs.len(),
                state: &state.state,
            }),
            Err(e) => Err(e.into()),
        };
        // Drops this run's values (the outputs, and the state's reference to the input), as
        // tract's own `run` does.
        let reset = state.state.reset_turn();
        let out = out?;
        reset?;
        Ok(out)
    }

    /// [`run_in`](Self::run_in) on a state taken from the network's pool (made on first use),
    /// returned to it afterwards. Concurrent callers each get their own state.
    pub fn run_pooled<R>(
        &self,
        fill: impl FnOnce(&mut [f32]),
        read: impl FnOnce(NetOutputs<'_>) -> Result<R>,
    ) -> Result<R> {
        let mut state = self.take_state()?;
        let out = self.run_in(&mut state, fill, read);
        self.give_back(state, out.is_ok())?;
        out
    }

    /// Two runs side by side on rayon's threads, on two states of the pool: `fill` writes
    /// both inputs at once (so that the second can be made from the first, e.g. a crop and
    /// its mirror image), then each run's outputs go through `read`.
    pub fn run_pooled_pair<R: Send>(
        &self,
        fill: impl FnOnce(&mut [f32], &mut [f32]),
        read: impl Fn(NetOutputs<'_>) -> Result<R> + Sync,
    ) -> Result<(R, R)> {
        let (mut a, mut b) = (self.take_state()?, self.take_state()?);
        self.with_input(&mut a, |x| self.with_input(&mut b, |y| fill(x, y)))??;
        // Where rayon has threads for both, the two runs go side by side from their first
        // operator: counted in flight before either starts, so that neither shares its
        // first operators with the team while the other is starting (three threads on two
        // cores; the browser measured it).
        let _pair = (rayon::current_num_threads() > 1).then(monohand_tflite::Running::start);
        let (ra, rb) = rayon::join(|| self.exec(&mut a, &read), || self.exec(&mut b, &read));
        self.give_back(a, ra.is_ok())?;
        self.give_back(b, rb.is_ok())?;
        Ok((ra?, rb?))
    }

    /// A state from the pool, or a new one if none is idle.
    fn take_state(&self) -> Result<NetState> {
        let idle = self.lock_pool()?.pop();
        match idle {
            Some(s) => Ok(s),
            None => self.new_state(),
        }
    }

    /// Returns `state` to the pool; a state whose run failed (`ok` false) is dropped
    /// rather than reused.
    fn give_back(&self, state: NetState, ok: bool) -> Result<()> {
        if ok {
            self.lock_pool()?.push(state);
        }
        Ok(())
    }

    fn lock_pool(&self) -> Result<std::sync::MutexGuard<'_, Vec<NetState>>> {
        self.pool
            .lock()
            .map_err(|_| VisionError::Inference("run state pool poisoned".into()))
    }

    /// Runs the network once on a fresh tract state; returns each output flattened to f32
    /// (copied). For repeated calls [`run_pooled`](Self::run_pooled) avoids the overhead.
    pub fn run(&self, input: Tensor) -> Result<Vec<Vec<f32>>> {
        if input.shape() != self.input_shape {
            return Err(VisionError::Inference(format!(
                "input shape {:?}, network expects {:?}",
                input.shape(),
                self.input_shape
            )));
        }
        let _running = monohand_tflite::Running::start();
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
