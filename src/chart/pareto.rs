//! The Pareto front of quality against cost: the points no other point
//! beats on both, i.e. the best quality reachable for a given cost.
//!
//! Rules:
//! 1. Lower cost is better. Quality is better higher (PSNR, SSIM) or lower
//!    (FLIP), per [`Better`].
//! 2. A point is on the front unless another point is at least as good on
//!    both and strictly better on one. Equal points are all on it.
//! 3. Points with a non-finite cost or quality are never on the front.
//! 4. The front is returned by increasing cost (ties: by point index), so
//!    its quality improves along it; drawn as a step line it is the best
//!    quality available at each cost.

/// Which direction of quality is better.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Better {
    /// Larger values are better (PSNR, SSIM).
    Higher,
    /// Smaller values are better (FLIP).
    Lower,
}

impl Better {
    /// True if quality `a` is at least as good as `b`.
    fn at_least(self, a: f64, b: f64) -> bool {
        match self {
            Better::Higher => a >= b,
            Better::Lower => a <= b,
        }
    }
}

/// Indices of the points `(cost, quality)` on the Pareto front, by
/// increasing cost (module rules).
pub fn pareto_front(points: &[(f64, f64)], better: Better) -> Vec<usize> {
    let ok = |p: &(f64, f64)| p.0.is_finite() && p.1.is_finite();
    let mut front: Vec<usize> = (0..points.len())
        .filter(|&i| ok(&points[i]))
        .filter(|&i| {
            let (c, q) = points[i];
            !points
                .iter()
                .any(|o| ok(o) && o.0 <= c && better.at_least(o.1, q) && (o.0 < c || !better.at_least(q, o.1)))
        })
        .collect();
    front.sort_by(|&a, &b| points[a].0.total_cmp(&points[b].0).then(a.cmp(&b)));
    front
}

/// The step line through a front (points in front order): from each point
/// across at its quality to the next point's cost, then to its quality.
pub fn step_line(front: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut line = Vec::new();
    for (i, &(c, q)) in front.iter().enumerate() {
        if i > 0 {
            line.push((c, front[i - 1].1));
        }
        line.push((c, q));
    }
    line
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn higher_quality_front_by_hand() {
        // cost, quality
        let p = [
            (1.0, 20.0),      // 0: cheapest -> front
            (2.0, 25.0),      // 1: better for more -> front
            (2.0, 22.0),      // 2: same cost, worse than 1 -> dominated
            (3.0, 24.0),      // 3: costlier and worse than 1 -> dominated
            (4.0, 30.0),      // 4: best quality -> front
            (0.5, 10.0),      // 5: cheapest of all -> front
            (5.0, 30.0),      // 6: same quality as 4 for more -> dominated
            (f64::NAN, 99.0), // 7: not finite -> never
        ];
        assert_eq!(pareto_front(&p, Better::Higher), vec![5, 0, 1, 4]);
    }

    #[test]
    fn lower_quality_is_better_for_flip() {
        let p = [(1.0, 0.30), (2.0, 0.20), (3.0, 0.25), (4.0, 0.10), (0.5, 0.40)];
        assert_eq!(pareto_front(&p, Better::Lower), vec![4, 0, 1, 3]);
        // The same points read as higher-is-better keep only the cheapest.
        assert_eq!(pareto_front(&p, Better::Higher), vec![4]);
    }

    #[test]
    fn ties_and_degenerate_inputs() {
        assert_eq!(pareto_front(&[], Better::Higher), Vec::<usize>::new());
        assert_eq!(pareto_front(&[(1.0, 1.0), (1.0, 1.0)], Better::Higher), vec![0, 1]);
        assert_eq!(pareto_front(&[(1.0, f64::INFINITY), (2.0, 3.0)], Better::Higher), vec![1]);
        assert_eq!(step_line(&[(1.0, 2.0), (3.0, 5.0)]), vec![(1.0, 2.0), (3.0, 2.0), (3.0, 5.0)]);
    }
}
