//! Following a target through a whole sequence held in memory (forward to the end, backward
//! to the start, from the frame it is given at), and the check of a full-frame starting mask.

use super::{FollowConfig, FollowError, FollowStep, Follower};
use crate::frame::{Detection, Frame, Mask};
use crate::segment::Net;

/// A mask from a full-frame bitmap, checked against the frame size and for emptiness.
pub fn mask_from_bitmap(
    width: u32,
    height: u32,
    mask_w: u32,
    mask_h: u32,
    bitmap: &[u8],
) -> Result<Mask, FollowError> {
    let size_err = FollowError::MaskSize {
        mask_width: mask_w,
        mask_height: mask_h,
        width,
        height,
    };
    if (mask_w, mask_h) != (width, height) {
        return Err(size_err);
    }
    let mask = Mask::from_full(width, height, bitmap).map_err(|_| size_err)?;
    if mask.is_empty() {
        return Err(FollowError::EmptyMask);
    }
    Ok(mask)
}

/// Follows a target given as `mask` at frame `init` (0-based) through all `frames`, forward
/// to the end and backward to the start. `detections`, when given, holds one list per frame.
/// Returns one step per frame (the initial frame: the given mask, confidence 1).
pub fn follow_sequence(
    frames: &[Frame<'_>],
    init: usize,
    mask: &Mask,
    detections: Option<&[Vec<Detection>]>,
    cfg: &FollowConfig,
) -> Result<Vec<FollowStep>, FollowError> {
    follow_sequence_with_net(frames, init, mask, detections, cfg, None)
}

/// [`follow_sequence`] with the learned segmentation run by `net` on each frame's
/// [`Follower::learned_crop`] ([`Follower::step_with_net`]), as `shapetrack follow` runs it
/// with its model installed; `None` is [`follow_sequence`].
pub fn follow_sequence_with_net(
    frames: &[Frame<'_>],
    init: usize,
    mask: &Mask,
    detections: Option<&[Vec<Detection>]>,
    cfg: &FollowConfig,
    mut net: Option<&mut dyn Net>,
) -> Result<Vec<FollowStep>, FollowError> {
    if frames.is_empty() {
        return Err(FollowError::NoFrames);
    }
    if init >= frames.len() {
        return Err(FollowError::FrameOutOfRange {
            frame: init,
            len: frames.len(),
        });
    }
    if let Some(d) = detections {
        if d.len() != frames.len() {
            return Err(FollowError::DetectionsLength {
                expected: frames.len(),
                got: d.len(),
            });
        }
    }
    let (w, h) = (frames[init].width(), frames[init].height());
    for (index, f) in frames.iter().enumerate() {
        if (f.width(), f.height()) != (w, h) {
            return Err(FollowError::FrameSize {
                index,
                got_width: f.width(),
                got_height: f.height(),
                width: w,
                height: h,
            });
        }
    }
    let first = Follower::new(&frames[init], mask, cfg.clone())?;
    let mut out = vec![None; frames.len()];
    out[init] = Some(FollowStep {
        mask: mask.tight(),
        confidence: 1.0,
        lost: false,
        stopped: false,
        inliers: 0,
        from_detection: false,
        from_learned: false,
    });
    let no_dets: Vec<Detection> = Vec::new();
    let dets = |i: usize| detections.map_or(&no_dets[..], |d| &d[i][..]);
    let mut step = |f: &mut Follower, i: usize| match net.as_deref_mut() {
        Some(n) => f.step_with_net(&frames[i], dets(i), n),
        None => f.step(&frames[i], dets(i)),
    };
    let mut fwd = first.clone();
    for (i, slot) in out.iter_mut().enumerate().skip(init + 1) {
        *slot = Some(step(&mut fwd, i)?);
    }
    let mut back = first;
    for (i, slot) in out.iter_mut().enumerate().take(init).rev() {
        *slot = Some(step(&mut back, i)?);
    }
    Ok(out.into_iter().flatten().collect())
}
