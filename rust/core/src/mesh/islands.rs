//! Connected components ("pieces", Blender's "loose parts") of a triangle mesh.

/// Label the connected components of a triangle mesh by union-find over its triangles.
///
/// Inputs: `n` vertex count, `triangles` `(m, 3)` indices `< n` (out-of-range triangles are
/// ignored). Outputs: `(labels, count)`, `labels` `(n,)` in `0..count`, numbered in order of
/// each component's lowest vertex index. A vertex used by no triangle is its own component.
/// Union by size with path halving: O(m alpha(n)).
pub fn connected_components(n: usize, triangles: &[[u32; 3]]) -> (Vec<u32>, usize) {
    let mut parent: Vec<u32> = (0..n as u32).collect();
    let mut size = vec![1u32; n];

    fn find(parent: &mut [u32], mut x: u32) -> u32 {
        while parent[x as usize] != x {
            let g = parent[parent[x as usize] as usize];
            parent[x as usize] = g;
            x = g;
        }
        x
    }

    for t in triangles {
        if t.iter().any(|&i| i as usize >= n) {
            continue;
        }
        for k in 1..3 {
            let a = find(&mut parent, t[0]);
            let b = find(&mut parent, t[k]);
            if a != b {
                let (big, small) = if size[a as usize] >= size[b as usize] { (a, b) } else { (b, a) };
                parent[small as usize] = big;
                size[big as usize] += size[small as usize];
            }
        }
    }

    let mut label_of_root = vec![u32::MAX; n];
    let mut labels = vec![0u32; n];
    let mut count = 0usize;
    for (v, label) in labels.iter_mut().enumerate() {
        let r = find(&mut parent, v as u32) as usize;
        if label_of_root[r] == u32::MAX {
            label_of_root[r] = count as u32;
            count += 1;
        }
        *label = label_of_root[r];
    }
    (labels, count)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_triangles_and_an_isolated_vertex() {
        let (labels, count) = connected_components(7, &[[0, 1, 2], [4, 5, 6], [2, 1, 0]]);
        assert_eq!(count, 3);
        assert_eq!(labels, vec![0, 0, 0, 1, 2, 2, 2]);
    }
}
