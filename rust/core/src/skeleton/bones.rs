//! A skeleton as the motion functions read it: one view of four parallel per-bone arrays.

/// A skeleton's bones, borrowed: `heads`, `tails` `(b, 3)` in one space (the armature's frame,
/// +Z up for roles and motion), `parents` `(b,)` (`-1` for a root), `names` `(b,)` or empty
/// (names are hints only; an empty list reads the geometry alone). The functions that take one
/// check it ([`crate::motion::detect_roles`]: as many tails, parents and names as heads, all
/// finite, parents a forest).
#[derive(Clone, Copy, Debug)]
pub struct Skeleton<'a> {
    pub heads: &'a [[f32; 3]],
    pub tails: &'a [[f32; 3]],
    pub parents: &'a [i32],
    pub names: &'a [String],
}

impl<'a> Skeleton<'a> {
    /// The view of these four arrays.
    pub fn new(heads: &'a [[f32; 3]], tails: &'a [[f32; 3]], parents: &'a [i32], names: &'a [String]) -> Self {
        Skeleton { heads, tails, parents, names }
    }

    /// The number of bones (of heads).
    pub fn len(&self) -> usize {
        self.heads.len()
    }

    /// Whether it has no bones.
    pub fn is_empty(&self) -> bool {
        self.heads.is_empty()
    }
}
