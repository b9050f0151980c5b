//! Exact floating-point expansion arithmetic (Shewchuk, "Adaptive Precision Floating-Point
//! Arithmetic and Fast Robust Geometric Predicates", 1997), enough for the oracle's
//! orientation test: the exact sign of `((a − o) × (b − o)) · d` for `f64` inputs.
//!
//! An expansion is a sum of non-overlapping `f64` components in increasing magnitude; its
//! value is exact. The sign of an expansion is the sign of its largest component. A
//! floating-point filter answers first; the exact path runs only when the filter cannot
//! decide, so the oracle stays fast on the many rays far from any edge.

/// `a + b` as `(rounded sum, rounding error)`, exactly.
fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let x = a + b;
    let bv = x - a;
    let av = x - bv;
    (x, (a - av) + (b - bv))
}

/// `a · b` as `(rounded product, rounding error)`, exactly (with a fused multiply-add).
fn two_product(a: f64, b: f64) -> (f64, f64) {
    let x = a * b;
    (x, a.mul_add(b, -x))
}

/// An exact sum of `f64` components, smallest magnitude first, zeros removed.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Expansion(Vec<f64>);

impl Expansion {
    /// The expansion of one number.
    pub fn from_f64(a: f64) -> Self {
        if a == 0.0 {
            Expansion(Vec::new())
        } else {
            Expansion(vec![a])
        }
    }

    /// `a − b`, exactly.
    pub fn diff(a: f64, b: f64) -> Self {
        let (x, y) = two_sum(a, -b);
        Expansion([y, x].into_iter().filter(|c| *c != 0.0).collect())
    }

    /// `self + b` for a single number (Shewchuk's GROW-EXPANSION with zero elimination).
    fn grow(&self, b: f64) -> Self {
        let mut q = b;
        let mut out = Vec::with_capacity(self.0.len() + 1);
        for &e in &self.0 {
            let (s, h) = two_sum(q, e);
            if h != 0.0 {
                out.push(h);
            }
            q = s;
        }
        if q != 0.0 {
            out.push(q);
        }
        Expansion(out)
    }

    /// `self + other`, exactly.
    pub fn add(&self, other: &Expansion) -> Self {
        other.0.iter().fold(self.clone(), |acc, &c| acc.grow(c))
    }

    /// `−self`.
    pub fn neg(&self) -> Self {
        Expansion(self.0.iter().map(|c| -c).collect())
    }

    /// `self − other`, exactly.
    pub fn sub(&self, other: &Expansion) -> Self {
        self.add(&other.neg())
    }

    /// `self · b` for a single number (SCALE-EXPANSION with zero elimination).
    fn scale(&self, b: f64) -> Self {
        let mut out = Vec::with_capacity(self.0.len() * 2);
        let mut iter = self.0.iter();
        let Some(&first) = iter.next() else {
            return Expansion(Vec::new());
        };
        let (mut q, h) = two_product(first, b);
        if h != 0.0 {
            out.push(h);
        }
        for &e in iter {
            let (p1, p0) = two_product(e, b);
            let (sum, h) = two_sum(q, p0);
            if h != 0.0 {
                out.push(h);
            }
            let (nq, h) = two_sum(p1, sum);
            if h != 0.0 {
                out.push(h);
            }
            q = nq;
        }
        if q != 0.0 {
            out.push(q);
        }
        Expansion(out)
    }

    /// `self · other`, exactly.
    pub fn mul(&self, other: &Expansion) -> Self {
        other
            .0
            .iter()
            .fold(Expansion::default(), |acc, &c| acc.add(&self.scale(c)))
    }

    /// −1, 0 or +1.
    pub fn sign(&self) -> i32 {
        match self.0.last() {
            None => 0,
            Some(c) if *c > 0.0 => 1,
            Some(_) => -1,
        }
    }

    /// The value rounded to `f64` (the sum of the components, largest last).
    pub fn estimate(&self) -> f64 {
        self.0.iter().sum()
    }
}

/// Unit roundoff of `f64`.
const EPS64: f64 = f64::EPSILON * 0.5;

/// The value of `((a − o) × (b − o)) · d` in `f64`, with an exact sign: `(estimate, sign)`.
///
/// This is the edge function of the directed edge `a → b` seen along the ray `o + t·d`: zero
/// when the ray's line meets the edge's line, positive when the line passes the edge
/// counter-clockwise (seen from behind the origin, looking along `d`). The estimate carries
/// the usual `f64` rounding; the sign is exact.
pub fn edge_function(a: [f64; 3], b: [f64; 3], o: [f64; 3], d: [f64; 3]) -> (f64, i32) {
    let ax = [a[0] - o[0], a[1] - o[1], a[2] - o[2]];
    let bx = [b[0] - o[0], b[1] - o[1], b[2] - o[2]];
    let c = [
        ax[1] * bx[2] - ax[2] * bx[1],
        ax[2] * bx[0] - ax[0] * bx[2],
        ax[0] * bx[1] - ax[1] * bx[0],
    ];
    let value = c[0] * d[0] + c[1] * d[1] + c[2] * d[2];
    // Error bound of the filter: each difference and product rounds once; the permanent
    // (the same sum with every term made positive) bounds every intermediate magnitude.
    let perm = ((ax[1] * bx[2]).abs() + (ax[2] * bx[1]).abs()) * d[0].abs()
        + ((ax[2] * bx[0]).abs() + (ax[0] * bx[2]).abs()) * d[1].abs()
        + ((ax[0] * bx[1]).abs() + (ax[1] * bx[0]).abs()) * d[2].abs();
    let bound = 16.0 * EPS64 * perm;
    if value.is_finite() && value.abs() > bound {
        return (value, if value > 0.0 { 1 } else { -1 });
    }
    let exact = exact_edge_function(a, b, o, d);
    (exact.estimate(), exact.sign())
}

/// `((a − o) × (b − o)) · d` as an exact expansion.
pub fn exact_edge_function(a: [f64; 3], b: [f64; 3], o: [f64; 3], d: [f64; 3]) -> Expansion {
    let ax: [Expansion; 3] = std::array::from_fn(|i| Expansion::diff(a[i], o[i]));
    let bx: [Expansion; 3] = std::array::from_fn(|i| Expansion::diff(b[i], o[i]));
    let dx: [Expansion; 3] = std::array::from_fn(|i| Expansion::from_f64(d[i]));
    let cross = |i: usize, j: usize| ax[i].mul(&bx[j]).sub(&ax[j].mul(&bx[i]));
    let c = [cross(1, 2), cross(2, 0), cross(0, 1)];
    c[0].mul(&dx[0])
        .add(&c[1].mul(&dx[1]))
        .add(&c[2].mul(&dx[2]))
}

/// Whether the cross product `(b − a) × (c − a)` is exactly zero: the triangle has no area.
pub fn is_degenerate(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> bool {
    let u: [Expansion; 3] = std::array::from_fn(|i| Expansion::diff(b[i], a[i]));
    let v: [Expansion; 3] = std::array::from_fn(|i| Expansion::diff(c[i], a[i]));
    let cross = |i: usize, j: usize| u[i].mul(&v[j]).sub(&u[j].mul(&v[i]));
    cross(1, 2).sign() == 0 && cross(2, 0).sign() == 0 && cross(0, 1).sign() == 0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn expansions_are_exact_where_f64_is_not() {
        // 1 + 2^-60 − 1 is 2^-60 exactly, which plain f64 loses.
        let e = Expansion::from_f64(1.0)
            .add(&Expansion::from_f64(2f64.powi(-60)))
            .sub(&Expansion::from_f64(1.0));
        assert_eq!(e.estimate(), 2f64.powi(-60));
        assert_eq!(e.sign(), 1);
        // (1 + 2^-30)^2 − 1 − 2^-29 = 2^-60.
        let a = Expansion::from_f64(1.0 + 2f64.powi(-30));
        let p = a
            .mul(&a)
            .sub(&Expansion::from_f64(1.0))
            .sub(&Expansion::from_f64(2f64.powi(-29)));
        assert_eq!(p.estimate(), 2f64.powi(-60));
        assert_eq!(Expansion::diff(3.0, 3.0).sign(), 0);
    }

    #[test]
    fn edge_function_sign_is_exact_on_the_edge() {
        // A ray through the midpoint of the edge (0,0,0)–(c,s,0) of a fan, from (0,0,-1):
        // the line meets the edge exactly, whatever rounding f64 would do.
        let c = (0.7f32).cos() as f64;
        let s = (0.7f32).sin() as f64;
        let o = [0.0, 0.0, -1.0];
        let d = [c / 2.0, s / 2.0, 1.0];
        let (_, sign) = edge_function([0.0, 0.0, 0.0], [c, s, 0.0], o, d);
        assert_eq!(sign, 0);
        // Nudging the direction by one f64 ulp moves the line off the edge, to one side.
        let d2 = [f64::from_bits(d[0].to_bits() + 1), d[1], d[2]];
        let (_, s2) = edge_function([0.0, 0.0, 0.0], [c, s, 0.0], o, d2);
        let d3 = [f64::from_bits(d[0].to_bits() - 1), d[1], d[2]];
        let (_, s3) = edge_function([0.0, 0.0, 0.0], [c, s, 0.0], o, d3);
        assert_eq!(s2, -s3);
        assert_ne!(s2, 0);
    }

    #[test]
    fn edge_function_far_from_the_origin() {
        // Coordinates near 1e6 with an edge the ray misses by 2^-30: the f64 filter cannot
        // decide, the exact path does.
        let base = 1.0e6;
        let a = [base, base, 0.0];
        let b = [base, base + 1.0, 0.0];
        let o = [base + 2f64.powi(-30), base + 0.5, -1.0];
        let d = [0.0, 0.0, 1.0];
        let (_, sign) = edge_function(a, b, o, d);
        let (_, flipped) = edge_function(b, a, o, d);
        assert_ne!(sign, 0);
        assert_eq!(sign, -flipped);
        let exact = exact_edge_function(a, b, o, d);
        assert_eq!(exact.sign(), sign);
    }

    #[test]
    fn degenerate_triangles() {
        assert!(is_degenerate([0.0; 3], [1.0, 1.0, 1.0], [2.0, 2.0, 2.0]));
        assert!(is_degenerate(
            [1.0, 2.0, 3.0],
            [1.0, 2.0, 3.0],
            [5.0, 0.0, 0.0]
        ));
        assert!(!is_degenerate([0.0; 3], [1.0, 0.0, 0.0], [0.0, 1e-30, 0.0]));
    }
}
