//! Working buffers a thread keeps between calls. The tracker's per-frame geometry and the
//! page's mask encoding run the same steps for every shape of every frame; allocating their
//! buffers each time was most of their allocations (issue 10: no allocation per frame in the
//! hot path). Each user keeps one value per thread in a const-initialised thread local and
//! borrows it through [`with_scratch`].

use std::cell::RefCell;
use std::thread::LocalKey;

/// A set of working buffers one thread reuses across calls.
pub(crate) trait Scratch: Sized {
    /// No buffers yet (a constant, so the thread local needs no lazy initialisation).
    const EMPTY: Self;

    /// Whether the buffers grew past what is worth keeping for the next call: one huge input
    /// (a ragged mask, thousands of stacked boxes) then does not hold its memory for the
    /// thread's life. Never, by default.
    fn oversized(&self) -> bool {
        false
    }
}

impl<T> Scratch for Vec<T> {
    const EMPTY: Self = Vec::new();
}

/// Runs `f` with this thread's buffers in `key`, or with fresh ones should they be in use
/// (no user nests its calls, but fresh buffers keep that case correct), and releases them
/// afterwards if they grew [`Scratch::oversized`].
pub(crate) fn with_scratch<T: Scratch, R>(
    key: &'static LocalKey<RefCell<T>>,
    f: impl FnOnce(&mut T) -> R,
) -> R {
    key.with(|cell| match cell.try_borrow_mut() {
        Ok(mut kept) => {
            let out = f(&mut kept);
            if kept.oversized() {
                *kept = T::EMPTY;
            }
            out
        }
        Err(_) => {
            let mut fresh = T::EMPTY;
            f(&mut fresh)
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Big(Vec<u8>);

    impl Scratch for Big {
        const EMPTY: Self = Big(Vec::new());
        fn oversized(&self) -> bool {
            self.0.capacity() > 100
        }
    }

    thread_local! {
        static BIG: RefCell<Big> = const { RefCell::new(Big::EMPTY) };
    }

    #[test]
    fn buffers_are_kept_unless_oversized_and_a_nested_call_gets_fresh_ones() {
        with_scratch(&BIG, |b| b.0.extend_from_slice(&[1; 10]));
        // Kept, contents and all (users clear what they reuse).
        assert_eq!(with_scratch(&BIG, |b| b.0.len()), 10);
        let nested = with_scratch(&BIG, |outer| {
            outer.0.push(2);
            with_scratch(&BIG, |inner| inner.0.len())
        });
        assert_eq!(nested, 0);
        with_scratch(&BIG, |b| b.0.extend_from_slice(&[3; 200]));
        BIG.with(|b| assert_eq!(b.borrow().0.capacity(), 0));
    }
}
