//! A cache of the learned segmentation's outputs for evaluation runs (`detect-eval`,
//! `follow --net-cache`): a grid of settings that changes only what happens after the network
//! (thresholds, fusion rules) re-runs in seconds instead of hours. Outputs are keyed by a hash
//! of the input tensor's bits, so a cached output is the one the network gave for exactly
//! that input. Never used by `detect` or `follow` themselves unless asked.
//!
//! With a cache folder, `SHAPETRACK_EVAL_NET="CMD ARGS…"` runs the network in that command
//! instead of tract (`PipeNet`: each input's side as a little-endian `u32` then its tensor to
//! the command's stdin, the output from its stdout, raw little-endian `f32`), e.g. `scripts/ort_net.py` with onnxruntime: the browser's runtime's
//! arithmetic at about four times tract's speed, for long evaluation grids. The crops, the
//! thresholds and everything after the network are the CLI's own either way.

use shapetrack::segment::{side_of_input, Net, SegmentError, INPUT_LEN};
use std::collections::hash_map::DefaultHasher;
use std::collections::HashMap;
use std::hash::{Hash, Hasher};
use std::path::PathBuf;

/// A [`Net`] that remembers its outputs, in memory and optionally in a folder.
pub struct CachedNet {
    inner: Box<dyn Net>,
    dir: Option<PathBuf>,
    memory: HashMap<u64, Vec<f32>>,
    /// Runs of the real network.
    pub misses: u64,
    /// Outputs served from the cache.
    pub hits: u64,
}

impl CachedNet {
    /// Wraps `inner`; `dir` (created when missing) keeps outputs between runs.
    pub fn new(inner: Box<dyn Net>, dir: Option<PathBuf>) -> std::io::Result<CachedNet> {
        let mut inner = inner;
        if let Some(d) = &dir {
            std::fs::create_dir_all(d)?;
            if let Some(cmd) = std::env::var_os("SHAPETRACK_EVAL_NET") {
                inner = Box::new(PipeNet::spawn(&cmd.to_string_lossy())?);
            }
        }
        Ok(CachedNet {
            inner,
            dir,
            memory: HashMap::new(),
            misses: 0,
            hits: 0,
        })
    }
}

fn key(input: &[f32]) -> u64 {
    let mut h = DefaultHasher::new();
    for v in input {
        v.to_bits().hash(&mut h);
    }
    input.len().hash(&mut h);
    h.finish()
}

impl Net for CachedNet {
    fn run(&mut self, input: &[f32]) -> Result<Vec<f32>, SegmentError> {
        let k = key(input);
        if let Some(v) = self.memory.get(&k) {
            self.hits += 1;
            return Ok(v.clone());
        }
        let file = self.dir.as_ref().map(|d| d.join(format!("{k:016x}.f32")));
        if let Some(bytes) = file.as_ref().and_then(|f| std::fs::read(f).ok()) {
            // One probability per pixel of the input's side: side² for 3·side² inputs.
            if bytes.len() == input.len() / 3 * 4 {
                let v: Vec<f32> = bytes
                    .chunks_exact(4)
                    .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
                    .collect();
                self.hits += 1;
                self.memory.insert(k, v.clone());
                return Ok(v);
            }
        }
        let v = self.inner.run(input)?;
        self.misses += 1;
        if let Some(f) = file {
            let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
            // A cache that cannot be written only costs time.
            let _ = std::fs::write(f, bytes);
        }
        // Memory is bounded by the folder when there is one; without it keep the last few
        // hundred (a sequence's worth).
        if self.memory.len() > 512 {
            self.memory.clear();
        }
        self.memory.insert(k, v.clone());
        Ok(v)
    }
}

/// One network shared by several users (runners made one after another in an evaluation).
#[derive(Clone)]
pub struct SharedNet(pub std::rc::Rc<std::cell::RefCell<CachedNet>>);

impl Net for SharedNet {
    fn run(&mut self, input: &[f32]) -> Result<Vec<f32>, SegmentError> {
        self.0.borrow_mut().run(input)
    }
}

/// The network run by another process (evaluation only, see the module's documentation).
struct PipeNet {
    child: std::process::Child,
}

impl PipeNet {
    fn spawn(cmd: &str) -> std::io::Result<PipeNet> {
        let mut parts = cmd.split_whitespace();
        let prog = parts
            .next()
            .ok_or_else(|| std::io::Error::other("SHAPETRACK_EVAL_NET is empty"))?;
        let child = std::process::Command::new(prog)
            .args(parts)
            .stdin(std::process::Stdio::piped())
            .stdout(std::process::Stdio::piped())
            .spawn()?;
        Ok(PipeNet { child })
    }
}

impl Net for PipeNet {
    fn run(&mut self, input: &[f32]) -> Result<Vec<f32>, SegmentError> {
        use std::io::{Read, Write};
        let fail = |e: std::io::Error| SegmentError::Model(format!("SHAPETRACK_EVAL_NET: {e}"));
        // The side first: a crop around a box and the whole frame run at different sides.
        let side = side_of_input(input.len()).ok_or(SegmentError::TensorLength {
            what: "the input tensor",
            len: input.len(),
            expected: INPUT_LEN,
        })?;
        let bytes: Vec<u8> = side
            .to_le_bytes()
            .into_iter()
            .chain(input.iter().flat_map(|x| x.to_le_bytes()))
            .collect();
        let (Some(stdin), Some(stdout)) = (self.child.stdin.as_mut(), self.child.stdout.as_mut())
        else {
            return Err(fail(std::io::Error::other("no pipe")));
        };
        stdin
            .write_all(&bytes)
            .and_then(|_| stdin.flush())
            .map_err(fail)?;
        let mut out = vec![0u8; side as usize * side as usize * 4];
        stdout.read_exact(&mut out).map_err(fail)?;
        Ok(out
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect())
    }
}

impl Drop for PipeNet {
    fn drop(&mut self) {
        // Closing its stdin ends the helper process's loop.
        self.child.stdin = None;
        let _ = self.child.wait();
    }
}
