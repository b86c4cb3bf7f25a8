//! What one ray's traversal prepares and carries: the ray's slab data ([`Prepared`]) and its
//! stack ([`Stack`] over slots on the call stack or, for deep trees, the heap) — shared by the
//! one-ray kernels (`kernels.rs`) and the packet kernel's hand-over to them (`packet.rs`).

use super::layout::*;

/// Slots on the call stack for a traversal stack; trees deeper than ~36 levels take a heap
/// buffer instead ([`stack_slots`]).
pub(super) const FIXED_SLOTS: usize = 256;

/// The slots of a traversal stack of at most `need` entries: the fixed array (not initialised:
/// only pushed slots are read) or, when it is too small, `heap`, sized once here.
#[inline(always)]
pub(super) fn stack_slots<'a>(
    fixed: &'a mut [std::mem::MaybeUninit<u32>; FIXED_SLOTS],
    heap: &'a mut Vec<std::mem::MaybeUninit<u32>>,
    need: usize,
) -> Stack<'a> {
    let slots: &'a mut [std::mem::MaybeUninit<u32>] = if need <= FIXED_SLOTS {
        fixed
    } else {
        heap.resize(need, std::mem::MaybeUninit::uninit());
        heap
    };
    Stack { slots, len: 0 }
}

/// A traversal stack over preallocated slots: a push is one checked store, a pop one load.
pub(super) struct Stack<'a> {
    pub(super) slots: &'a mut [std::mem::MaybeUninit<u32>],
    pub(super) len: usize,
}

impl Stack<'_> {
    #[inline(always)]
    pub(super) fn push(&mut self, v: u32) {
        // Checked: the slots are sized for the tree's depth, so this never fails.
        self.slots[self.len].write(v);
        self.len += 1;
    }
    #[inline(always)]
    pub(super) fn pop(&mut self) -> Option<u32> {
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        // SAFETY: `len < slots.len()` (it was pushed), and slots below `len` were written by
        // `push`.
        Some(unsafe { self.slots.get_unchecked(self.len).assume_init() })
    }
}

/// Uninitialised slots for [`stack_slots`] (built without writing them: an array-repeat
/// expression here was compiled to a 1 KiB `memset` per traversal).
#[inline(always)]
pub(super) fn uninit_slots() -> [std::mem::MaybeUninit<u32>; FIXED_SLOTS] {
    // SAFETY: an array of `MaybeUninit` needs no initialisation.
    unsafe { std::mem::MaybeUninit::uninit().assume_init() }
}

/// A ray prepared for the slab tests: reciprocal direction, `o·inv`, and for each axis the
/// node rows of the near and far planes (chosen once per ray, so the box test has no branch).
pub(super) struct Prepared {
    pub(super) inv: [f32; 3],
    pub(super) oi: [f32; 3],
    pub(super) near: [usize; 3],
    pub(super) far: [usize; 3],
}

impl Prepared {
    #[inline(always)]
    pub(super) fn new(ray: &WideRay) -> Self {
        let mut inv = [0.0f32; 3];
        for a in 0..3 {
            let d = ray.d[a];
            // Zero (or denormal-small) components become ±TINY_DIR: no 0·∞ in the test.
            let d = if d.abs() < TINY_DIR {
                TINY_DIR.copysign(d)
            } else {
                d
            };
            inv[a] = 1.0 / d;
        }
        let oi = [ray.o[0] * inv[0], ray.o[1] * inv[1], ray.o[2] * inv[2]];
        Self::with(inv, oi)
    }

    /// Lane `i` of the packet kernel's reciprocals and `o·inv`, which it computes 8 lanes at
    /// a time with the same operations as [`Prepared::new`] (so the values are identical).
    #[inline(always)]
    pub(super) fn lane(inv: &[[f32; 8]; 3], oi: &[[f32; 8]; 3], i: usize) -> Self {
        Self::with(
            [inv[0][i], inv[1][i], inv[2][i]],
            [oi[0][i], oi[1][i], oi[2][i]],
        )
    }

    #[inline(always)]
    pub(super) fn with(inv: [f32; 3], oi: [f32; 3]) -> Self {
        let mut near = [0usize; 3];
        let mut far = [0usize; 3];
        for a in 0..3 {
            let neg = usize::from(inv[a] < 0.0);
            near[a] = a + 3 * neg;
            far[a] = a + 3 * (1 - neg);
        }
        Self { inv, oi, near, far }
    }
}
