//! Welding plain points (`mesh::weld::weld_points`, the Python `weld_points`): the first point
//! of a cluster represents it, no chaining, non-finite input.

use miniskeleton_core::mesh::weld::weld_points;

#[test]
fn the_first_point_represents_its_cluster_and_clusters_do_not_chain() {
    // 0.6 apart in a row, tolerance 1: the third point is 0.6 from the second but 1.2 from the
    // first, the cluster's representative, so it starts a cluster of its own.
    let points = [[0.0, 0.0, 0.0], [0.6, 0.0, 0.0], [1.2, 0.0, 0.0], [1.8, 0.0, 0.0], [0.0, 0.9, 0.0]];
    let (map, welded) = weld_points(&points, 1.0);
    assert_eq!(map, [0, 0, 1, 1, 0]);
    assert_eq!(welded, [points[0], points[2]]); // first points, not means
                                                // at exactly the tolerance still one point
    assert_eq!(weld_points(&[[1.0, 2.0, 3.0], [1.0, 2.0, 3.5]], 0.5).0, [0, 0]);
}

#[test]
fn exact_duplicates_only_without_a_positive_tolerance_and_non_finite_points_stay_apart() {
    let points = [[0.0, 0.0, 0.0], [1e-9, 0.0, 0.0], [0.0, 0.0, 0.0], [-0.0, 0.0, 0.0]];
    for tolerance in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let (map, welded) = weld_points(&points, tolerance);
        assert_eq!(map, [0, 1, 0, 0], "{tolerance}");
        assert_eq!(welded.len(), 2);
    }
    let odd = [[f64::NAN, 0.0, 0.0], [f64::NAN, 0.0, 0.0], [f64::INFINITY, 0.0, 0.0], [f64::INFINITY, 0.0, 0.0]];
    for tolerance in [0.0, 1.0] {
        assert_eq!(weld_points(&odd, tolerance).0, [0, 1, 2, 3]);
    }
    assert_eq!(weld_points(&[], 1.0), (vec![], vec![]));
}
