//! The parent list of a skeleton, checked once for every algorithm that takes one (heat on
//! imported rigs, bilinear weights, roles and motion clips).

use crate::{Error, Result};

/// Validate a parent list for `b` bones: `(b,)`, each `-1` (a root) or another bone's index,
/// and no cycle (walking up from any bone reaches a root). Errors: [`Error::Shape`] for the
/// length, [`Error::InvalidArgument`] naming the first bad bone.
pub fn validate_parents(parents: &[i32], b: usize) -> Result<()> {
    if parents.len() != b {
        return Err(Error::Shape(format!("{} parents for {b} bones", parents.len())));
    }
    for (i, &p) in parents.iter().enumerate() {
        if p < -1 || p >= b as i32 || p == i as i32 {
            return Err(Error::InvalidArgument(format!(
                "parent of bone {i} is {p}; it must be -1 or another bone's index (0..{b})"
            )));
        }
    }
    // 0 = not seen, 1 = on the current walk up, 2 = known to reach a root.
    let mut state = vec![0u8; b];
    for start in 0..b {
        let mut cur = start as i32;
        while cur >= 0 && state[cur as usize] == 0 {
            state[cur as usize] = 1;
            cur = parents[cur as usize];
        }
        if cur >= 0 && state[cur as usize] == 1 {
            return Err(Error::InvalidArgument(format!("bone {cur} is in a parent cycle")));
        }
        let mut cur = start as i32;
        while cur >= 0 && state[cur as usize] == 1 {
            state[cur as usize] = 2;
            cur = parents[cur as usize];
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_parents_are_errors() {
        validate_parents(&[-1, 0, 1, 1, -1, 4], 6).unwrap();
        assert!(matches!(validate_parents(&[-1, 0], 3), Err(Error::Shape(_))));
        assert!(matches!(validate_parents(&[-1, 1], 2), Err(Error::InvalidArgument(_))));
        assert!(matches!(validate_parents(&[-1, 2], 2), Err(Error::InvalidArgument(_))));
        assert!(matches!(validate_parents(&[-2, 0], 2), Err(Error::InvalidArgument(_))));
        // Cycles: two bones, three bones below a root, and one reached only through a chain.
        for parents in [vec![1, 0], vec![-1, 3, 1, 2], vec![-1, 0, 4, 2, 3, 2]] {
            let err = validate_parents(&parents, parents.len()).unwrap_err();
            assert!(err.to_string().contains("parent cycle"), "{parents:?}: {err}");
        }
    }
}
