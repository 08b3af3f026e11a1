//! The network natively, on `tract` (pure Rust: no native library to find or download, and
//! the same crate would build for wasm32 if the browser ever needed it).
//!
//! Why not onnxruntime natively (the `ort` crate): it would have to load the C++ library
//! from a package's files at run time (its default build downloads binaries from a host the
//! project's machines cannot reach), and it differs from the browser's runtime anyway (wasm
//! kernels there). tract is slower per run (measured in `tests/data/detect/README.md`), which
//! the CLI's policy of running the network only where it decides something absorbs.

use super::{model, side_of_input, Net, SegmentError, INPUT_LEN, SIDE};
use std::path::Path;
use tract_onnx::prelude::*;

type Plan = std::sync::Arc<TypedRunnableModel>;

/// U²-Net-p on tract, optimised for each input side it is given (`[1, 3, side, side]`, one
/// plan per side, made when first needed), computing only the first (fused) output: the six
/// side outputs are training aids and cost convolutions.
pub struct TractNet {
    model: InferenceModel,
    plans: Vec<(usize, Plan)>,
    runs: u64,
}

impl std::fmt::Debug for TractNet {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TractNet")
            .field("runs", &self.runs)
            .finish()
    }
}

impl TractNet {
    /// Loads and checks the model (see [`model::load`] for where it is looked for).
    pub fn load(explicit: Option<&Path>) -> Result<TractNet, SegmentError> {
        let (_, bytes) = model::load(explicit)?;
        TractNet::from_bytes(&bytes)
    }

    /// The network from the model file's bytes (checked against the published hash first).
    pub fn from_bytes(bytes: &[u8]) -> Result<TractNet, SegmentError> {
        model::verify(bytes).map_err(SegmentError::Model)?;
        let err = |e: TractError| SegmentError::Model(format!("u2netp.onnx: {e}"));
        let mut m = tract_onnx::onnx()
            .model_for_read(&mut std::io::Cursor::new(bytes))
            .map_err(err)?;
        let first = *m.output_outlets().map_err(err)?.first().ok_or_else(|| {
            SegmentError::Model("u2netp.onnx: the model has no output".to_string())
        })?;
        m.select_output_outlets(&[first]).map_err(err)?;
        let mut net = TractNet {
            model: m,
            plans: Vec::new(),
            runs: 0,
        };
        // The model's own side now: a model that does not optimise fails here, not later.
        net.plan(SIDE)?;
        Ok(net)
    }

    /// The plan for inputs of `side` (the model's declared 320 replaced by it: its resizes
    /// follow the input's shape).
    fn plan(&mut self, side: usize) -> Result<Plan, SegmentError> {
        if let Some((_, p)) = self.plans.iter().find(|(s, _)| *s == side) {
            return Ok(p.clone());
        }
        let err = |e: TractError| SegmentError::Model(format!("u2netp.onnx at {side}: {e}"));
        let mut m = self.model.clone();
        m.set_input_fact(0, f32::fact([1, 3, side, side]).into())
            .map_err(err)?;
        let outlet = m.output_outlets().map_err(err)?[0];
        // The declared output shape is the file's 320; the side's own follows from the input.
        m.set_outlet_fact(outlet, InferenceFact::default())
            .map_err(err)?;
        let plan = m
            .into_optimized()
            .and_then(|m| m.into_runnable())
            .map_err(err)?;
        self.plans.push((side, plan.clone()));
        Ok(plan)
    }

    /// How many times the network has run.
    pub fn runs(&self) -> u64 {
        self.runs
    }
}

impl Net for TractNet {
    fn run(&mut self, input: &[f32]) -> Result<Vec<f32>, SegmentError> {
        let side = side_of_input(input.len()).ok_or(SegmentError::TensorLength {
            what: "the input tensor",
            len: input.len(),
            expected: INPUT_LEN,
        })? as usize;
        let t = Tensor::from_shape(&[1, 3, side, side], input)
            .map_err(|e| SegmentError::Run(e.to_string()))?;
        let out = self
            .plan(side)?
            .run(tvec!(t.into()))
            .map_err(|e| SegmentError::Run(e.to_string()))?;
        self.runs += 1;
        let first = out
            .first()
            .ok_or_else(|| SegmentError::Run("no output".to_string()))?;
        let v = first
            .to_plain_array_view::<f32>()
            .ok()
            .and_then(|a| a.to_slice().map(<[f32]>::to_vec))
            .ok_or_else(|| "the output is not a contiguous f32 tensor".to_string())
            .map_err(|e| SegmentError::Run(e.to_string()))?;
        if v.len() != side * side {
            return Err(SegmentError::TensorLength {
                what: "the network's output",
                len: v.len(),
                expected: side * side,
            });
        }
        Ok(v)
    }
}
