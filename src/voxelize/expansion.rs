//! The far field of triangle clusters for the winding number, with rigorous
//! error bounds: each cluster's [`Multipole`] (its dipole, first moment and
//! second moment: third order, one beyond Barill et al. 2018) and, over a
//! box, the fast multipole method's *local* expansion ([`LocalExpansion`]):
//! one degree-2 polynomial about the box's centre that serves every box
//! inside it ([`LocalExpansion::recentred`]).
//!
//! The higher terms are what make tight bounds affordable: a cluster of
//! radius `r` at distance `g` errs by `O(A r³/g⁵)` with three terms,
//! `O(A r²/g⁴)` with two and `O(A r/g³)` with the dipole alone, so a given
//! bound comes at a smaller opening ratio, with fewer triangles left to sum
//! one by one. The truncation dominated the bricks' bounds with two terms
//! (twenty times the Taylor remainders on the finest holed meshes), hence
//! the third.

use glam::{DMat3, DVec3};

const FOUR_PI: f64 = 4.0 * std::f64::consts::PI;

/// The far field of a set of tree nodes and triangles over a box, as a local
/// (Taylor) expansion of degree 2 about the box's centre, with an upper bound
/// of its error over the whole box.
///
/// For a node's [`Multipole`] (centre `p`, radius `r`) seen from the box of
/// centre `c` and radius `ρ` (half-diagonal) at `d = |p − c|`, four errors
/// are bounded ([`LocalExpansion::add_multipole`]): the multipole's
/// truncation over the box, and the Taylor remainders after degree 2 of its
/// three terms. The `k`-th derivative tensor of `1/|x|` has norm at most
/// `k!/|x|^{k+1}` (Legendre polynomials are bounded by 1, and a symmetric
/// tensor's norm is its largest value on the diagonal), and every term is a
/// contraction of such derivatives.
///
/// ```
/// use glam::DVec3;
/// use voxkit::voxelize::winding::WindingTree;
/// // A small closed tetrahedron far from a box: its far field is 0 ± error.
/// let v = [[256, 256, 256], [256, -256, -256], [-256, 256, -256], [-256, -256, 256]];
/// let t = WindingTree::new(&[[v[0], v[1], v[2]], [v[0], v[3], v[1]], [v[0], v[2], v[3]], [v[1], v[3], v[2]]]);
/// let f = t.far_field(DVec3::splat(20.0), DVec3::splat(27.0), 1.0);
/// assert!(f.near.is_empty());
/// assert!(f.local.eval(DVec3::splat(22.0)).abs() <= f.local.error);
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LocalExpansion {
    /// The expansion point (the box's centre).
    pub centre: DVec3,
    /// Value at the centre.
    pub value: f64,
    /// Gradient at the centre.
    pub gradient: DVec3,
    /// Hessian at the centre: `xx, yy, zz, xy, yz, zx`.
    pub hessian: [f64; 6],
    /// `|far field − eval| ≤ error` over the box it was built for.
    pub error: f64,
}

impl LocalExpansion {
    /// An empty expansion about `centre`.
    pub fn new(centre: DVec3) -> Self {
        LocalExpansion {
            centre,
            ..Default::default()
        }
    }

    /// The expansion's value at `q`.
    #[inline]
    pub fn eval(&self, q: DVec3) -> f64 {
        let h = q - self.centre;
        let [xx, yy, zz, xy, yz, zx] = self.hessian;
        let quad = h.x * (xx * h.x + 2.0 * (xy * h.y + zx * h.z))
            + h.y * (yy * h.y + 2.0 * yz * h.z)
            + zz * h.z * h.z;
        self.value + self.gradient.dot(h) + 0.5 * quad
    }

    /// The same polynomial about another centre (exact algebra: a quadratic
    /// re-expanded; the error bound is kept, so `centre` should lie in the
    /// box the expansion was built for and the new box inside it).
    pub fn recentred(&self, centre: DVec3) -> Self {
        let d = centre - self.centre;
        let [xx, yy, zz, xy, yz, zx] = self.hessian;
        let hd = DVec3::new(
            xx * d.x + xy * d.y + zx * d.z,
            xy * d.x + yy * d.y + yz * d.z,
            zx * d.x + yz * d.y + zz * d.z,
        );
        LocalExpansion {
            centre,
            value: self.value + self.gradient.dot(d) + 0.5 * hd.dot(d),
            gradient: self.gradient + hd,
            hessian: self.hessian,
            error: self.error,
        }
    }

    /// Adds a node's multipole (dipole, first- and second-moment terms, see
    /// [`Multipole`]) as seen from a box of radius `rho` about the centre,
    /// with its four error terms over the box: the multipole's truncation
    /// ([`Multipole::truncation`] at the box's nearest distance `d − ρ`),
    /// and the Taylor remainders after degree 2 of its three parts. With
    /// `u = ρ/d`: the dipole part's `k`-th Taylor term is
    /// `D^{k+1}φ[N, h^k]/k!`, at most `(k+1)|N| ρ^k / d^{k+2}`, summing over
    /// `k ≥ 3` to `|N| u³ (4 − 3u) / ((1 − u)² d²)`; the moment part's is at
    /// most `(k+1)(k+2) M₁ ρ^k / d^{k+3}`, summing to
    /// `M₁ u³ (20 − 30u + 12u²) / ((1 − u)³ d³)`; the third part's (`T`
    /// contracted with `D^{k+3}φ`, `|T(a, b, c)| ≤ S₂` for unit vectors) at
    /// most `(S₂/2)(k+1)(k+2)(k+3) ρ^k / d^{k+4}`, summing to
    /// `(S₂/2) u³ (120 − 270u + 216u² − 60u³) / ((1 − u)⁴ d⁴)` (derivatives of `1/|x|`
    /// of order `k` have norm `k!/|x|^{k+1}`; all over `4π`). The caller
    /// guarantees `|p − centre| > r + rho`.
    pub fn add_multipole(&mut self, m: &Multipole, rho: f64) {
        self.add_multipoles(&[m], rho);
    }

    /// [`LocalExpansion::add_multipole`] for each of `poles` in turn: the
    /// same sums, bit for bit (each node's terms are computed by the same
    /// operations, [`M2L_LANES`] nodes at a time in vector lanes, then added
    /// in order).
    pub fn add_multipoles(&mut self, poles: &[&Multipole], rho: f64) {
        #[cfg(target_arch = "x86_64")]
        let avx2 = std::arch::is_x86_feature_detected!("avx2");
        for chunk in poles.chunks(M2L_LANES) {
            // Short chunks repeat their last node in the unused lanes.
            let lanes: [&Multipole; M2L_LANES] =
                std::array::from_fn(|l| chunk[l.min(chunk.len() - 1)]);
            #[cfg(target_arch = "x86_64")]
            let t = if avx2 {
                // SAFETY: the CPU runs AVX2 (checked above); the kernel uses
                // no intrinsics, only the wider registers.
                unsafe { m2l_terms_avx2(self.centre, rho, &lanes) }
            } else {
                m2l_terms(self.centre, rho, &lanes)
            };
            #[cfg(not(target_arch = "x86_64"))]
            let t = m2l_terms(self.centre, rho, &lanes);
            for l in 0..chunk.len() {
                self.value += t.value[l];
                self.gradient += DVec3::new(t.gradient[0][l], t.gradient[1][l], t.gradient[2][l]);
                for (acc, h) in self.hessian.iter_mut().zip(&t.hessian) {
                    *acc -= h[l];
                }
                self.error += t.error[l];
            }
        }
    }
}

/// Multipoles per call of the translation kernel (`m2l_terms`).
pub const M2L_LANES: usize = 4;

/// What [`LocalExpansion::add_multipole`] adds for each of [`M2L_LANES`]
/// nodes: value, gradient, Hessian (subtracted) and error terms, by lane.
struct M2lTerms {
    value: [f64; M2L_LANES],
    gradient: [[f64; M2L_LANES]; 3],
    hessian: [[f64; M2L_LANES]; 6],
    error: [f64; M2L_LANES],
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn m2l_terms_avx2(centre: DVec3, rho: f64, poles: &[&Multipole; M2L_LANES]) -> M2lTerms {
    m2l_terms(centre, rho, poles)
}

/// The terms of [`LocalExpansion::add_multipole`] for `poles` seen from the
/// box of radius `rho` about `centre`, one node per lane: the fields are
/// gathered lane by lane, then every lane runs the same straight-line
/// arithmetic (in the order of the scalar formulas below, so that each
/// lane's terms are those of the scalar code, bit for bit), which the
/// compiler turns into vector instructions.
///
/// With `y = p − c`, `r = |y|`, `sᵢ = r^−i`, `N` the dipole, `S` the moment
/// and `t = tr S`: the value is `k((N·y + t)s₃ − 3(y·Sy)s₅)`, the gradient
/// `k(y(3(N·y + t)s₅ − 15(y·Sy)s₇) + 6s₅ Sy − s₃N)`, and the Hessian `−k`
/// times `a y yᵀ + (v yᵀ + y vᵀ) + 6s₅ S + c I` with `a = 105(y·Sy)s₉ −
/// 15(N·y + t)s₇`, `v = 3s₅N − 30s₇ Sy`, `c = 3(N·y + t)s₅ − 15(y·Sy)s₇`
/// (`k = 1/4π`; derivation and error terms at
/// [`LocalExpansion::add_multipole`]).
#[inline(always)]
fn m2l_terms(centre: DVec3, rho: f64, poles: &[&Multipole; M2L_LANES]) -> M2lTerms {
    let y = each3!(i => gather(poles, |m| m.centre[i] - centre[i]));
    let n = each3!(i => gather(poles, |m| m.normal[i]));
    // `sc[i][j]` is `S_ij` (`moment.col(j)[i]`).
    let sc = each3!(i => each3!(j => gather(poles, |m| m.moment.col(j)[i])));
    let radius = gather(poles, |m| m.radius);
    let k = Lanes::splat(1.0 / FOUR_PI);
    let c = Lanes::splat;
    let r = (y[0] * y[0] + y[1] * y[1] + y[2] * y[2]).sqrt();
    let inv_r = c(1.0) / r;
    let inv_r2 = inv_r * inv_r;
    let s3 = inv_r2 * inv_r;
    let s5 = s3 * inv_r2;
    let s7 = s5 * inv_r2;
    let s9 = s7 * inv_r2;
    let ny = n[0] * y[0] + n[1] * y[1] + n[2] * y[2];
    // S y, column by column (glam's order).
    let sy = each3!(i => sc[i][0] * y[0] + sc[i][1] * y[1] + sc[i][2] * y[2]);
    let ysy = y[0] * sy[0] + y[1] * sy[1] + y[2] * sy[2];
    let tr = sc[0][0] + sc[1][1] + sc[2][2];
    let value = k * ((ny + tr) * s3 - c(3.0) * ysy * s5);
    let a1 = (c(3.0) * (ny + tr)) * s5 - c(15.0) * ysy * s7;
    let gradient = each3!(i => k * (y[i] * a1 + sy[i] * (c(6.0) * s5) - n[i] * s3));
    let a = c(105.0) * ysy * s9 - c(15.0) * (ny + tr) * s7;
    let v = each3!(i => n[i] * (c(3.0) * s5) - sy[i] * (c(30.0) * s7));
    let diag = c(3.0) * (ny + tr) * s5 - c(15.0) * ysy * s7;
    let s6 = c(6.0) * s5;
    macro_rules! h {
        ($i:expr, $j:expr) => {
            a * y[$i] * y[$j] + (v[$i] * y[$j] + v[$j] * y[$i]) + s6 * sc[$i][$j]
        };
    }
    let hessian = [
        k * (h!(0, 0) + diag),
        k * (h!(1, 1) + diag),
        k * (h!(2, 2) + diag),
        k * h!(0, 1),
        k * h!(1, 2),
        k * h!(2, 0),
    ];
    // The third-order term `f = (k/2)(15 P s₇ − 9 L s₅)` with `P = T(y,y,y)`,
    // `L = τ·y`, `v = T(y,y,·)`, `W = T(y,·,·)`: value `f`, gradient `−∇f`,
    // Hessian `∇²f` (`∇P = 3v`, `∇²P = 6W`).
    let mut t = [Lanes::splat(0.0); 10];
    for (i, ti) in t.iter_mut().enumerate() {
        *ti = gather(poles, |m| m.third[i]);
    }
    let (w, tv) = third_contractions(&t, y);
    let p3 = tv[0] * y[0] + tv[1] * y[1] + tv[2] * y[2];
    let tau = each3!(i => gather(poles, |m| m.third_trace[i]));
    let l3 = tau[0] * y[0] + tau[1] * y[1] + tau[2] * y[2];
    let s11 = s9 * inv_r2;
    let half_k = c(0.5) * k;
    let value3 = half_k * (c(15.0) * p3 * s7 - c(9.0) * l3 * s5);
    let gradient3 = each3!(i => half_k
        * (c(9.0) * (tau[i] * s5 - c(5.0) * l3 * y[i] * s7)
            - c(15.0) * (c(3.0) * tv[i] * s7 - c(7.0) * p3 * y[i] * s9)));
    let diag3 = c(15.0) * (c(-7.0) * p3 * s9) - c(9.0) * (c(-5.0) * l3 * s7);
    macro_rules! h3 {
        ($i:expr, $j:expr, $wij:expr) => {
            c(15.0)
                * (c(6.0) * $wij * s7 - c(21.0) * (tv[$i] * y[$j] + y[$i] * tv[$j]) * s9
                    + c(63.0) * p3 * y[$i] * y[$j] * s11)
                - c(9.0)
                    * (c(35.0) * l3 * y[$i] * y[$j] * s9
                        - c(5.0) * (tau[$i] * y[$j] + y[$i] * tau[$j]) * s7)
        };
    }
    let hessian3 = [
        half_k * (h3!(0, 0, w[0]) + diag3),
        half_k * (h3!(1, 1, w[1]) + diag3),
        half_k * (h3!(2, 2, w[2]) + diag3),
        half_k * h3!(0, 1, w[3]),
        half_k * h3!(1, 2, w[4]),
        half_k * h3!(2, 0, w[5]),
    ];
    // Taylor remainders after degree 2 and the truncation at `r − ρ`.
    let rho = c(rho);
    let gr = r - rho;
    let inv_gr = c(1.0) / gr;
    let u = rho * inv_r;
    let u3 = u * u * u;
    let dipole = gather(poles, |m| m.normal_length) * u3 * (c(4.0) - c(3.0) * u) * inv_gr * inv_gr;
    let moment = gather(poles, |m| m.first)
        * u3
        * (c(20.0) - c(30.0) * u + c(12.0) * u * u)
        * inv_gr
        * inv_gr
        * inv_gr;
    // The third-order term's `m`-th Taylor term is at most
    // `(S₂/2)(m+1)(m+2)(m+3) ρ^m / d^{m+4}`; summed over `m ≥ 3`,
    // `(S₂/2) u³ (120 − 270u + 216u² − 60u³) / ((1 − u)⁴ d⁴)`.
    let inv_gr2 = inv_gr * inv_gr;
    let third = c(0.5)
        * gather(poles, |m| m.second)
        * u3
        * (c(120.0) - c(270.0) * u + c(216.0) * u * u - c(60.0) * u3)
        * (inv_gr2 * inv_gr2);
    let g = gr - radius;
    let truncation = gather(poles, |m| m.cubic) * (c(4.0) * gr - c(3.0) * radius)
        / (g * g * (gr * gr) * (gr * gr));
    M2lTerms {
        value: (value + value3).0,
        gradient: each3!(i => (gradient[i] + gradient3[i]).0),
        hessian: [
            (hessian[0] - hessian3[0]).0,
            (hessian[1] - hessian3[1]).0,
            (hessian[2] - hessian3[2]).0,
            (hessian[3] - hessian3[3]).0,
            (hessian[4] - hessian3[4]).0,
            (hessian[5] - hessian3[5]).0,
        ],
        error: (k * (truncation + dipole + moment + third)).0,
    }
}

/// `[e(0), e(1), e(2)]` written out: in the translation kernel a closure
/// or an array's `map` can stay an out-of-line call, compiled without the
/// kernel's AVX2 (callgrind: a third of its instructions were in two such
/// calls).
macro_rules! each3 {
    ($i:ident => $e:expr) => {
        [
            {
                let $i = 0usize;
                $e
            },
            {
                let $i = 1usize;
                $e
            },
            {
                let $i = 2usize;
                $e
            },
        ]
    };
}
use each3;

/// One field of each of `poles`, lane by lane.
#[inline(always)]
fn gather(poles: &[&Multipole; M2L_LANES], f: impl Fn(&Multipole) -> f64) -> Lanes {
    let mut out = [0.0; M2L_LANES];
    for (o, m) in out.iter_mut().zip(poles) {
        *o = f(m);
    }
    Lanes(out)
}

/// [`M2L_LANES`] `f64` values operated on lane by lane (each operation a
/// loop the compiler turns into one vector instruction).
#[derive(Clone, Copy)]
struct Lanes([f64; M2L_LANES]);

impl Lanes {
    #[inline(always)]
    fn splat(v: f64) -> Self {
        Lanes([v; M2L_LANES])
    }

    #[inline(always)]
    fn sqrt(self) -> Self {
        let mut out = self.0;
        for v in &mut out {
            *v = v.sqrt();
        }
        Lanes(out)
    }
}

macro_rules! lanes_op {
    ($trait:ident, $f:ident, $op:tt) => {
        impl std::ops::$trait for Lanes {
            type Output = Lanes;
            #[inline(always)]
            fn $f(self, o: Lanes) -> Lanes {
                let mut out = self.0;
                for (a, b) in out.iter_mut().zip(o.0) {
                    *a $op b;
                }
                Lanes(out)
            }
        }
    };
}
lanes_op!(Add, add, +=);
lanes_op!(Sub, sub, -=);
lanes_op!(Mul, mul, *=);
lanes_op!(Div, div, /=);

/// A cluster of triangles as seen from afar: the first three terms of the
/// Taylor expansion of the kernel about the cluster's centre `p`.
///
/// `w(q) = (1/4π) Σ_t ∫_t n_t · (x − q)/|x − q|³ dA`; expanding the kernel
/// in `x` about `p` to second order gives the dipole `N = Σ_t A_t` (area
/// vectors), the moment `M = Σ_t A_t (c_t − p)ᵀ` (`c_t` the centroids:
/// exact, the integrand being linear), of which only the symmetric part
/// counts, and the second moment `T_ijk = Σ_t ∫_t n_i h_j h_k dA`
/// (`h = x − p`; exact from the corners, `∫_t h hᵀ dA = (A/12)(Σ u uᵀ +
/// (Σ u)(Σ u)ᵀ)`), of which only the fully symmetric part counts. Its
/// share of `w` at `y = p − q` is `(15 T(y,y,y)/|y|⁷ − 9 τ·y/|y|⁵)/8π`
/// (`τ_m = Σ_i T_iim`). Summing the rest of the Taylor series, the
/// truncation error at distance `D` from `p` is at most
/// `S₃ (4 − 3t)/(4π (1 − t)² D⁵)`, `t = r / D`, with
/// `S₃ ≥ Σ_t ∫_t |x − p|³ dA` ([`Multipole::truncation`]): `O(A r³/D⁵)`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Multipole {
    /// Expansion point `p` (the area-weighted centroid).
    pub centre: DVec3,
    /// Radius of the ball about `p` holding every vertex.
    pub radius: f64,
    /// Area vector `N`.
    pub normal: DVec3,
    /// `|N|`.
    pub normal_length: f64,
    /// Total absolute area.
    pub abs_area: f64,
    /// Symmetric part of `M`.
    pub moment: DMat3,
    /// `M₁ = Σ_t |A_t| |c_t − p|` (bounds the nuclear norm of `M`).
    pub first: f64,
    /// `S₂ = Σ_t ∫_t |x − p|² dA` (bounds the third-order term's norm).
    pub second: f64,
    /// The third-order moment `T_ijk = Σ_t ∫_t n_i h_j h_k dA` (`h = x − p`,
    /// `n` the unit normal), fully symmetrised (only that part meets the
    /// symmetric derivative tensors), as `xxx yyy zzz xxy xxz xyy xzz yyz
    /// yzz xyz`.
    pub third: [f64; 10],
    /// `τ_m = Σ_i T_iim` of the symmetrised `T`.
    pub third_trace: DVec3,
    /// `S₃ ≥ Σ_t ∫_t |x − p|³ dA` (each triangle's `∫ |h|² dA` times its
    /// farthest corner's distance).
    pub cubic: f64,
}

/// `W = T(y, ·, ·)` (`W_mn = Σ_k T_mnk y_k`, as `xx yy zz xy yz zx`) and
/// `v = T(y, y, ·) = W y` of a symmetric 3-tensor `t` stored as
/// [`Multipole::third`] is; for `f64` and for the translation kernel's lanes
/// alike.
#[inline(always)]
fn third_contractions<T>(t: &[T; 10], y: [T; 3]) -> ([T; 6], [T; 3])
where
    T: Copy + std::ops::Add<Output = T> + std::ops::Mul<Output = T>,
{
    let w = [
        t[0] * y[0] + t[3] * y[1] + t[4] * y[2],
        t[5] * y[0] + t[1] * y[1] + t[7] * y[2],
        t[6] * y[0] + t[8] * y[1] + t[2] * y[2],
        t[3] * y[0] + t[5] * y[1] + t[9] * y[2],
        t[9] * y[0] + t[7] * y[1] + t[8] * y[2],
        t[4] * y[0] + t[9] * y[1] + t[6] * y[2],
    ];
    let v = [
        w[0] * y[0] + w[3] * y[1] + w[5] * y[2],
        w[3] * y[0] + w[1] * y[1] + w[4] * y[2],
        w[5] * y[0] + w[4] * y[1] + w[2] * y[2],
    ];
    (w, v)
}

/// A triangle's parts that do not depend on an expansion centre, which
/// [`Multipole::of_parts`] would otherwise recompute at every level of a
/// tree.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TriangleParts {
    /// The corners.
    pub corners: [DVec3; 3],
    /// The area vector `½ (b − a) × (c − a)`.
    pub area_vector: DVec3,
    /// Its length, the area.
    pub area: f64,
    /// The area times the centroid: the triangle's share of the
    /// area-weighted centre.
    pub weighted: DVec3,
}

impl TriangleParts {
    /// The parts of the triangle `t`.
    pub fn new(t: [DVec3; 3]) -> Self {
        let area_vector = 0.5 * (t[1] - t[0]).cross(t[2] - t[0]);
        let area = area_vector.length();
        TriangleParts {
            corners: t,
            area_vector,
            area,
            weighted: area * (t[0] + t[1] + t[2]) / 3.0,
        }
    }

    /// The centroid.
    pub fn centroid(&self) -> DVec3 {
        (self.corners[0] + self.corners[1] + self.corners[2]) / 3.0
    }
}

impl Multipole {
    /// The multipole of `tris` about their area-weighted centroid (the
    /// centre of their bounding box when they have no area).
    pub fn of(tris: impl Iterator<Item = [DVec3; 3]>) -> Self {
        let parts: Vec<TriangleParts> = tris.map(TriangleParts::new).collect();
        Self::of_parts(parts.iter())
    }

    /// [`Multipole::of`] from triangles whose centre-free parts are already
    /// computed (a tree computes them once for all its levels): the same
    /// value, bit for bit.
    pub fn of_parts<'a>(tris: impl Iterator<Item = &'a TriangleParts> + Clone) -> Self {
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        let (mut normal, mut abs_area, mut weighted) = (DVec3::ZERO, 0.0, DVec3::ZERO);
        for t in tris.clone() {
            for p in t.corners {
                lo = lo.min(p);
                hi = hi.max(p);
            }
            normal += t.area_vector;
            abs_area += t.area;
            weighted += t.weighted;
        }
        let centre = if abs_area > 0.0 {
            weighted / abs_area
        } else {
            (lo + hi) * 0.5
        };
        let (mut radius, mut first, mut second, mut cubic) = (0.0f64, 0.0, 0.0, 0.0);
        let mut third = [0.0; 10];
        let mut m = DMat3::ZERO;
        for t in tris {
            let u = t.corners.map(|p| p - centre);
            let far = u.iter().map(|p| p.length()).fold(0.0, f64::max);
            radius = radius.max(far);
            let (n, a) = (t.area_vector, t.area);
            let c = (u[0] + u[1] + u[2]) / 3.0;
            // n cᵀ: column j is n c_j.
            m += DMat3::from_cols(n * c.x, n * c.y, n * c.z);
            first += a * c.length();
            // ∫_t x xᵀ dA = A/12 (Σ u uᵀ + (Σ u)(Σ u)ᵀ), traced.
            let su = u[0] + u[1] + u[2];
            let spread = a / 12.0
                * (u[0].length_squared()
                    + u[1].length_squared()
                    + u[2].length_squared()
                    + su.length_squared());
            second += spread;
            cubic += far * spread;
            // ∫_t h hᵀ dA = (A/12)(Σ u uᵀ + (Σ u)(Σ u)ᵀ); with the area
            // vector `n` (= A n̂) the 1/A cancels. `q` is 12 times that
            // (`xx yy zz xy yz zx`), the symmetrisation's 1/3 and the 1/12
            // applied once at the end.
            let qq = |j: usize, k: usize| {
                u[0][j] * u[0][k] + u[1][j] * u[1][k] + u[2][j] * u[2][k] + su[j] * su[k]
            };
            let q = [qq(0, 0), qq(1, 1), qq(2, 2), qq(0, 1), qq(1, 2), qq(2, 0)];
            let (nx, ny, nz) = (n.x, n.y, n.z);
            third[0] += 3.0 * nx * q[0];
            third[1] += 3.0 * ny * q[1];
            third[2] += 3.0 * nz * q[2];
            third[3] += nx * q[3] + nx * q[3] + ny * q[0];
            third[4] += nx * q[5] + nx * q[5] + nz * q[0];
            third[5] += nx * q[1] + ny * q[3] + ny * q[3];
            third[6] += nx * q[2] + nz * q[5] + nz * q[5];
            third[7] += ny * q[4] + ny * q[4] + nz * q[1];
            third[8] += ny * q[2] + nz * q[4] + nz * q[4];
            third[9] += nx * q[4] + ny * q[5] + nz * q[3];
        }
        Multipole {
            centre,
            // Rounding of the corners' distances must not shrink the ball.
            radius: radius * (1.0 + 1e-12),
            normal,
            normal_length: normal.length(),
            abs_area,
            moment: (m + m.transpose()) * 0.5,
            first,
            second: second * (1.0 + 1e-12),
            third: third.map(|t| t / 36.0),
            third_trace: DVec3::new(
                third[0] + third[5] + third[6],
                third[3] + third[1] + third[8],
                third[4] + third[7] + third[2],
            ) / 36.0,
            cubic: cubic * (1.0 + 1e-12),
        }
    }

    /// The multipole of two clusters together, from theirs (the fast
    /// multipole method's M2M shift) instead of from their triangles; `lo`,
    /// `hi` bound every vertex of both. A tree builds its large nodes so
    /// (one shift a node, where summing the triangles costs one pass over
    /// them at every level).
    ///
    /// The dipole and the moments are shifted exactly (up to rounding):
    /// with `d = p_c − p` from the new centre `p` to a child's,
    /// `M' = M + N dᵀ` (symmetric part) and `T' = T + sym(2 M ⊗ d + N ⊗ d ⊗
    /// d)`. The bounds are bounds again: `S₂' = S₂ + A|d|²` (its cross term
    /// `2 d · ∫h dA` vanishes about a child's area-weighted centroid, up to
    /// that centroid's rounding, which a margin covers), `M₁' ≤ M₁ + A|d|`,
    /// `S₃'` the smaller of `S₃ + 3|d| S₂ + 3|d|² √(A S₂) + |d|³ A`
    /// (`∫|h| ≤ √(A ∫|h|²)`) and `r' S₂'`, and the radius `r'` the smaller
    /// of the children's balls grown by `|d|` and the ball about `p`
    /// through the box's farthest corner. Bounds shifted so are looser than
    /// a sum over the triangles, never smaller
    /// (`merged_multipoles_agree_and_bound`).
    pub fn merge(a: &Multipole, b: &Multipole, lo: DVec3, hi: DVec3) -> Multipole {
        let abs_area = a.abs_area + b.abs_area;
        let normal = a.normal + b.normal;
        let centre = if abs_area > 0.0 {
            (a.centre * a.abs_area + b.centre * b.abs_area) / abs_area
        } else {
            (lo + hi) * 0.5
        };
        let corner = (centre - lo).abs().max((hi - centre).abs()).length();
        let mut out = Multipole {
            centre,
            radius: 0.0,
            normal,
            normal_length: normal.length(),
            abs_area,
            moment: DMat3::ZERO,
            first: 0.0,
            second: 0.0,
            third: [0.0; 10],
            third_trace: DVec3::ZERO,
            cubic: 0.0,
        };
        let mut grown = 0.0f64;
        for c in [a, b] {
            let d = c.centre - centre;
            let dl = d.length();
            let nd = DMat3::from_cols(c.normal * d.x, c.normal * d.y, c.normal * d.z);
            out.moment += c.moment + (nd + nd.transpose()) * 0.5;
            out.first += c.first + c.abs_area * dl;
            // The child's centre is its area-weighted centroid up to the
            // rounding of its sums (far below 10⁻¹² relative): the cross
            // term `2 d · A (c̄ − p_c)` is covered by this margin.
            let cross = 2.0 * dl * c.abs_area * 1e-12 * (c.centre.length() + dl);
            out.second += c.second + c.abs_area * dl * dl + cross;
            out.cubic += c.cubic
                + 3.0 * dl * c.second
                + 3.0 * dl * dl * (c.abs_area * c.second).sqrt()
                + dl * dl * dl * c.abs_area;
            grown = grown.max(c.radius + dl);
            let s = |i: usize, j: usize| c.moment.col(j)[i];
            let n = c.normal.to_array();
            let v = d.to_array();
            let shift = |i: usize, j: usize, k: usize| {
                (2.0 * (s(i, j) * v[k] + s(i, k) * v[j] + s(j, k) * v[i])
                    + (n[i] * v[j] * v[k] + n[j] * v[i] * v[k] + n[k] * v[i] * v[j]))
                    / 3.0
            };
            const ORDER: [[usize; 3]; 10] = [
                [0, 0, 0],
                [1, 1, 1],
                [2, 2, 2],
                [0, 0, 1],
                [0, 0, 2],
                [0, 1, 1],
                [0, 2, 2],
                [1, 1, 2],
                [1, 2, 2],
                [0, 1, 2],
            ];
            for (t, [i, j, k]) in out.third.iter_mut().zip(ORDER) {
                *t += shift(i, j, k);
            }
            for (t, ct) in out.third.iter_mut().zip(c.third) {
                *t += ct;
            }
        }
        let t = out.third;
        out.third_trace = DVec3::new(t[0] + t[5] + t[6], t[3] + t[1] + t[8], t[4] + t[7] + t[2]);
        out.radius = grown.min(corner) * (1.0 + 1e-12);
        out.second *= 1.0 + 1e-12;
        // Or, every point lying within the radius, `∫|h|³ ≤ r ∫|h|²`.
        out.cubic = out.cubic.min(out.radius * out.second) * (1.0 + 1e-12);
        out.first *= 1.0 + 1e-12;
        out
    }

    /// `tr S`, the moment's trace.
    fn moment_trace(&self) -> f64 {
        self.moment.x_axis.x + self.moment.y_axis.y + self.moment.z_axis.z
    }

    /// The multipole's value at `q` and the bound of its truncation error
    /// there, `None` within `radius` of the centre.
    pub fn at(&self, q: DVec3) -> Option<(f64, f64)> {
        let y = self.centre - q;
        let r2 = y.length_squared();
        let r = r2.sqrt();
        let g = r - self.radius;
        if g.is_nan() || g <= 0.0 {
            return None;
        }
        let s3 = 1.0 / (r2 * r);
        let ysy = y.dot(self.moment * y);
        let (s5, s7) = (s3 / r2, s3 / (r2 * r2));
        let cube = self.third_cubed(y);
        let third = 0.5 * (15.0 * cube * s7 - 9.0 * self.third_trace.dot(y) * s5);
        let value = (self.normal.dot(y) * s3 - (3.0 * ysy / r2 - self.moment_trace()) * s3 + third)
            / FOUR_PI;
        Some((value, self.truncation(r) / FOUR_PI))
    }

    /// `T(y, y, y)` of the symmetrised third moment.
    fn third_cubed(&self, y: DVec3) -> f64 {
        let (_, v) = third_contractions(&self.third, y.to_array());
        v[0] * y.x + v[1] * y.y + v[2] * y.z
    }

    /// `4π` times the bound of the truncation error at every point at least
    /// `dist > radius` from the centre: `S₃ (4 − 3t) / ((1 − t)² D⁵)`,
    /// `t = radius / D`, `D = dist`.
    ///
    /// Why: with `y = p − q` and `h = x − p`, the Taylor series of
    /// `1/|y + h|` in `h` has homogeneous terms `H_l(h) = D^l φ(y)[h^l]/l!`
    /// (`φ = 1/|·|`), and the kernel `n·∇_h` of the first three
    /// (`l = 1, 2, 3`) is what the dipole, the moment and the third-order
    /// term sum. The rest is `Σ_{l≥4} D^l φ(y)[n, h^{l−1}]/(l−1)!`, and
    /// since the symmetric tensor `D^l φ(y)` has norm `l!/|y|^{l+1}` (its
    /// largest directional derivative, `l! P_l / |y|^{l+1}` with
    /// `|P_l| ≤ 1`), each term is at most `l |h|^{l−1} / D^{l+1}`. Summed,
    /// `Σ_{l≥4} l t^{l−1} = t³ (4 − 3t)/(1 − t)²` with `t = |h|/D < 1`;
    /// over the cluster, `(4 − 3t)/(1 − t)²` grows with `|h| ≤ radius`, so
    /// the integral is at most `S₃ (4 − 3t)/((1 − t)² D⁵)`. Against the
    /// second-order truncation `S₂ (3 − 2t)/((1 − t)² D⁴)` this is about
    /// `(4/3) r/D` as large: a third at `D = 4r`.
    pub fn truncation(&self, dist: f64) -> f64 {
        // The same, multiplied out: one division.
        let g = dist - self.radius;
        self.cubic * (4.0 * dist - 3.0 * self.radius) / (g * g * dist * dist * dist * dist)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::voxelize::winding::solid_angle;
    use rand::{Rng, SeedableRng};

    fn random_vec(rng: &mut rand::rngs::StdRng, r: f64) -> DVec3 {
        DVec3::new(
            rng.random_range(-r..r),
            rng.random_range(-r..r),
            rng.random_range(-r..r),
        )
    }

    fn exact(tris: &[[DVec3; 3]], q: DVec3) -> f64 {
        tris.iter()
            .map(|t| solid_angle(t[0] - q, t[1] - q, t[2] - q))
            .sum::<f64>()
            / FOUR_PI
    }

    /// A cluster's multipole at a point, and its local expansion over a
    /// ball, stay within their bounds of direct summation, from far away
    /// down to a hair outside the cluster's ball; and the second-order
    /// bound is far tighter than the dipole's `2 A r / (4π g³)` where it
    /// matters (a few radii away).
    #[test]
    fn multipoles_hold_their_bounds() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(17);
        let mut tightest = 0.0f64;
        let mut gain = Vec::new();
        for trial in 0..300 {
            let n = rng.random_range(1..40);
            let spread = rng.random_range(0.5..10.0);
            let size = rng.random_range(0.2..4.0);
            let tris: Vec<[DVec3; 3]> = (0..n)
                .map(|_| {
                    let c = random_vec(&mut rng, spread);
                    [0; 3].map(|_| c + random_vec(&mut rng, size))
                })
                .collect();
            let m = Multipole::of(tris.iter().copied());
            let dir = random_vec(&mut rng, 1.0).normalize_or(DVec3::Z);
            let rho = [0.0, 0.87, 2.6, 6.1][trial % 4];
            let gap = (m.radius + rho) * [1e-3, 0.1, 0.5, 1.0, 3.0, 8.0][(trial / 4) % 6];
            let c = m.centre + dir * (m.radius + rho + gap);
            let mut local = LocalExpansion::new(c);
            local.add_multipole(&m, rho);
            for _ in 0..10 {
                let h = random_vec(&mut rng, 1.0).clamp_length_max(1.0) * rho;
                let q = c + h;
                let truth = exact(&tris, q);
                let err = (local.eval(q) - truth).abs();
                assert!(
                    err <= local.error + 1e-12,
                    "trial {trial}: {err} > {}",
                    local.error
                );
                let (v, e) = m.at(q).expect("outside the ball");
                assert!(
                    (v - truth).abs() <= e + 1e-12,
                    "point: {} > {e}",
                    (v - truth).abs()
                );
                if e > 1e-9 {
                    tightest = tightest.max((v - truth).abs() / e);
                }
                let g = (m.centre - q).length() - m.radius;
                if rho == 0.0 && g > 2.0 * m.radius && m.radius > 0.0 {
                    gain.push(2.0 * m.abs_area * m.radius / (FOUR_PI * g * g * g) / e);
                }
            }
        }
        // Not vacuous: somewhere the error comes within 1/30 of the bound.
        assert!(tightest > 1.0 / 30.0, "worst error / bound {tightest}");
        gain.sort_by(f64::total_cmp);
        assert!(
            gain[gain.len() / 2] > 1.5,
            "median gain over the dipole bound {}",
            gain[gain.len() / 2]
        );
    }

    /// The glam form of one translation (the formulas of
    /// [`LocalExpansion::add_multipole`] on vectors and matrices): the lane
    /// kernel must give its terms bit for bit.
    fn translate_glam(local: &mut LocalExpansion, m: &Multipole, rho: f64) {
        let y = m.centre - local.centre;
        let r = y.length();
        let inv_r = 1.0 / r;
        let inv_r2 = inv_r * inv_r;
        let (s3, k) = (inv_r2 * inv_r, 1.0 / FOUR_PI);
        let (s5, s7) = (s3 * inv_r2, s3 * inv_r2 * inv_r2);
        let s9 = s7 * inv_r2;
        let (n, s) = (m.normal, m.moment);
        let (ny, sy) = (n.dot(y), s * y);
        let (ysy, tr) = (y.dot(sy), m.moment_trace());
        let value2 = k * ((ny + tr) * s3 - 3.0 * ysy * s5);
        let grad2 = k * (y * ((3.0 * (ny + tr)) * s5 - 15.0 * ysy * s7) + sy * (6.0 * s5) - n * s3);
        let a = 105.0 * ysy * s9 - 15.0 * (ny + tr) * s7;
        let v = n * (3.0 * s5) - sy * (30.0 * s7);
        let c = 3.0 * (ny + tr) * s5 - 15.0 * ysy * s7;
        let h = |i: usize, j: usize| {
            a * y[i] * y[j] + (v[i] * y[j] + v[j] * y[i]) + 6.0 * s5 * s.col(j)[i]
        };
        let hess = [
            h(0, 0) + c,
            h(1, 1) + c,
            h(2, 2) + c,
            h(0, 1),
            h(1, 2),
            h(2, 0),
        ];
        // The third-order term, by the same scalar steps as the lanes.
        let (w, tv) = third_contractions(&m.third, y.to_array());
        let p3 = tv[0] * y.x + tv[1] * y.y + tv[2] * y.z;
        let tau = m.third_trace;
        let l3 = tau.x * y.x + tau.y * y.y + tau.z * y.z;
        let s11 = s9 * inv_r2;
        let half_k = 0.5 * k;
        let value3 = half_k * (15.0 * p3 * s7 - 9.0 * l3 * s5);
        let grad3 = DVec3::from_array([0, 1, 2].map(|i| {
            half_k
                * (9.0 * (tau[i] * s5 - 5.0 * l3 * y[i] * s7)
                    - 15.0 * (3.0 * tv[i] * s7 - 7.0 * p3 * y[i] * s9))
        }));
        let diag3 = 15.0 * (-7.0 * p3 * s9) - 9.0 * (-5.0 * l3 * s7);
        let h3 = |i: usize, j: usize, wij: f64| {
            15.0 * (6.0 * wij * s7 - 21.0 * (tv[i] * y[j] + y[i] * tv[j]) * s9
                + 63.0 * p3 * y[i] * y[j] * s11)
                - 9.0 * (35.0 * l3 * y[i] * y[j] * s9 - 5.0 * (tau[i] * y[j] + y[i] * tau[j]) * s7)
        };
        let hess3 = [
            h3(0, 0, w[0]) + diag3,
            h3(1, 1, w[1]) + diag3,
            h3(2, 2, w[2]) + diag3,
            h3(0, 1, w[3]),
            h3(1, 2, w[4]),
            h3(2, 0, w[5]),
        ];
        // The lanes add each node's parts first, then into the sums.
        local.value += value2 + value3;
        local.gradient += grad2 + grad3;
        for ((acc, v), v3) in local.hessian.iter_mut().zip(hess).zip(hess3) {
            *acc -= k * v - half_k * v3;
        }
        let gr = r - rho;
        let (inv_gr, u) = (1.0 / gr, rho * inv_r);
        let u3 = u * u * u;
        let dipole = m.normal_length * u3 * (4.0 - 3.0 * u) * inv_gr * inv_gr;
        let moment = m.first * u3 * (20.0 - 30.0 * u + 12.0 * u * u) * inv_gr * inv_gr * inv_gr;
        let inv_gr2 = inv_gr * inv_gr;
        let third = 0.5
            * m.second
            * u3
            * (120.0 - 270.0 * u + 216.0 * u * u - 60.0 * u3)
            * (inv_gr2 * inv_gr2);
        let g = gr - m.radius;
        let truncation = m.cubic * (4.0 * gr - 3.0 * m.radius) / (g * g * (gr * gr) * (gr * gr));
        local.error += k * (truncation + dipole + moment + third);
    }

    /// Translations in lanes (any count, any CPU path) equal the glam form
    /// one node at a time, bit for bit: batching changes no decision.
    #[test]
    fn translations_in_lanes_equal_one_at_a_time() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(11);
        let bits = |l: &LocalExpansion| {
            let mut v = vec![l.value, l.error];
            v.extend(l.gradient.to_array());
            v.extend(l.hessian);
            v.into_iter().map(f64::to_bits).collect::<Vec<_>>()
        };
        for trial in 0..200 {
            let count = 1 + trial % 23;
            let poles: Vec<Multipole> = (0..count)
                .map(|_| {
                    let c = random_vec(&mut rng, 40.0);
                    let tris: Vec<[DVec3; 3]> = (0..rng.random_range(1..9))
                        .map(|_| [0; 3].map(|_| c + random_vec(&mut rng, 1.5)))
                        .collect();
                    Multipole::of(tris.iter().copied())
                })
                .collect();
            let rho = [0.87, 2.6, 6.1][trial % 3];
            let centre = random_vec(&mut rng, 1.0) + DVec3::new(100.0, 0.0, 0.0);
            let refs: Vec<&Multipole> = poles.iter().collect();
            let mut lanes = LocalExpansion::new(centre);
            lanes.add_multipoles(&refs, rho);
            let mut glam = LocalExpansion::new(centre);
            for m in &poles {
                translate_glam(&mut glam, m, rho);
            }
            assert_eq!(bits(&lanes), bits(&glam), "trial {trial}");
            // The portable kernel, whatever the CPU.
            let mut portable = LocalExpansion::new(centre);
            for m in &poles {
                let t = m2l_terms(centre, rho, &[m; M2L_LANES]);
                portable.value += t.value[0];
                portable.gradient +=
                    DVec3::new(t.gradient[0][0], t.gradient[1][0], t.gradient[2][0]);
                for (acc, h) in portable.hessian.iter_mut().zip(&t.hessian) {
                    *acc -= h[0];
                }
                portable.error += t.error[0];
            }
            assert_eq!(bits(&portable), bits(&glam), "trial {trial}, portable");
        }
    }

    /// Parent multipoles need not be built from children: a multipole is
    /// the same whatever order its triangles come in.
    #[test]
    fn multipoles_do_not_depend_on_order() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(3);
        let tris: Vec<[DVec3; 3]> = (0..20)
            .map(|_| [0; 3].map(|_| random_vec(&mut rng, 5.0)))
            .collect();
        let a = Multipole::of(tris.iter().copied());
        let b = Multipole::of(tris.iter().rev().copied());
        assert!((a.centre - b.centre).length() < 1e-12);
        assert!((a.second - b.second).abs() < 1e-9 * a.second);
        assert!(a.moment.abs_diff_eq(b.moment, 1e-9 * (1.0 + a.first)));
    }

    /// Multipoles merged up a tree of leaves (the tree's large nodes) equal
    /// the direct sums in the shifted moments and bound what they bound:
    /// radius, `M₁`, `S₂` and `S₃` against their true values (the last by
    /// quadrature), and not vacuously.
    #[test]
    fn merged_multipoles_agree_and_bound() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(11);
        for trial in 0..300 {
            let n = 8 * rng.random_range(2..20);
            let spread = [0.01, 1.0, 40.0][trial % 3];
            let offset = random_vec(&mut rng, [0.5, 5.0, 3000.0][trial / 3 % 3]);
            let tris: Vec<[DVec3; 3]> = (0..n)
                .map(|_| {
                    let c = offset + random_vec(&mut rng, spread);
                    [0; 3].map(|_| c + random_vec(&mut rng, spread * 0.3))
                })
                .collect();
            // Leaves of 8, merged pairwise up to the root.
            let mut level: Vec<(Multipole, DVec3, DVec3)> = tris
                .chunks(8)
                .map(|c| {
                    let (lo, hi) = c.iter().flatten().fold(
                        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
                        |(l, h), p| (l.min(*p), h.max(*p)),
                    );
                    (Multipole::of(c.iter().copied()), lo, hi)
                })
                .collect();
            while level.len() > 1 {
                level = level
                    .chunks(2)
                    .map(|p| match p {
                        [a, b] => {
                            let (lo, hi) = (a.1.min(b.1), a.2.max(b.2));
                            (Multipole::merge(&a.0, &b.0, lo, hi), lo, hi)
                        }
                        [a] => *a,
                        _ => unreachable!(),
                    })
                    .collect();
            }
            let m = level[0].0;
            let d = Multipole::of(tris.iter().copied());
            let scale = d.radius.max(1e-300);
            assert!(
                (m.centre - d.centre).length() <= 1e-9 * scale,
                "trial {trial} centre"
            );
            let close = |a: f64, b: f64, size: f64| (a - b).abs() <= 1e-9 * size;
            assert!(close(m.abs_area, d.abs_area, d.abs_area));
            assert!((m.normal - d.normal).length() <= 1e-9 * d.abs_area);
            let msize = d.abs_area * scale;
            for j in 0..3 {
                assert!(
                    (m.moment.col(j) - d.moment.col(j)).length() <= 1e-9 * msize,
                    "trial {trial} moment"
                );
            }
            let tsize = d.abs_area * scale * scale;
            for k in 0..10 {
                assert!(
                    close(m.third[k], d.third[k], tsize),
                    "trial {trial} third {k}: {} vs {}",
                    m.third[k],
                    d.third[k]
                );
            }
            assert!((m.third_trace - d.third_trace).length() <= 1e-9 * tsize);
            // The centroid's margin may add up to ~10⁻⁹ |p| r A (|p| ≫ r
            // here at times: a cluster 10⁻² wide 3,000 from the origin).
            let margin = 1e-9 * d.second + 1e-10 * offset.length() * scale * d.abs_area;
            assert!(
                m.second >= d.second * (1.0 - 1e-13) && m.second <= d.second + margin,
                "trial {trial} second {} vs {}",
                m.second,
                d.second
            );
            // True values about the merged centre.
            let p = m.centre;
            let far = tris
                .iter()
                .flatten()
                .map(|v| (*v - p).length())
                .fold(0.0, f64::max);
            assert!(
                m.radius >= far && m.radius <= 3.0 * far.max(1e-300),
                "trial {trial} radius {} vs {far}",
                m.radius
            );
            let first: f64 = tris
                .iter()
                .map(|t| {
                    let a = 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length();
                    a * ((t[0] + t[1] + t[2]) / 3.0 - p).length()
                })
                .sum();
            assert!(m.first >= first * (1.0 - 1e-12), "trial {trial} first");
            // ∫|x − p|³ dA by the midpoint rule on each triangle split 16².
            let k = 16;
            let mut cubic = 0.0;
            for t in &tris {
                let area = 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length() / (k * k) as f64;
                let (e1, e2) = ((t[1] - t[0]) / k as f64, (t[2] - t[0]) / k as f64);
                for i in 0..k {
                    for j in 0..k - i {
                        let c = t[0] + e1 * (i as f64 + 1.0 / 3.0) + e2 * (j as f64 + 1.0 / 3.0);
                        cubic += area * (c - p).length().powi(3);
                        if i + j + 1 < k {
                            let c =
                                t[0] + e1 * (i as f64 + 2.0 / 3.0) + e2 * (j as f64 + 2.0 / 3.0);
                            cubic += area * (c - p).length().powi(3);
                        }
                    }
                }
            }
            assert!(
                m.cubic >= cubic * (1.0 - 1e-2),
                "trial {trial} cubic {} vs {cubic}",
                m.cubic
            );
            assert!(
                m.cubic <= 20.0 * d.cubic.max(1e-300),
                "trial {trial} cubic {} vs direct {}",
                m.cubic,
                d.cubic
            );
        }
    }

    /// The Taylor part of a local expansion's bound alone, against the
    /// multipole's own value (no truncation): it holds, and it is tight (a
    /// loose bound here once hid a wrong power of the distance).
    #[test]
    fn taylor_remainders_hold_and_are_tight() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(5);
        let mut tightest = 0.0f64;
        for _ in 0..2000 {
            let n = rng.random_range(1..6);
            let tris: Vec<[DVec3; 3]> = (0..n)
                .map(|_| {
                    let c = random_vec(&mut rng, 3.0);
                    [0; 3].map(|_| c + random_vec(&mut rng, 1.0))
                })
                .collect();
            let m = Multipole::of(tris.iter().copied());
            let rho = rng.random_range(0.5..6.0);
            let dir = random_vec(&mut rng, 1.0).normalize_or(DVec3::Z);
            let d = (m.radius + rho) * rng.random_range(1.001..3.0);
            let c = m.centre + dir * d;
            let mut local = LocalExpansion::new(c);
            local.add_multipole(&m, rho);
            let taylor = local.error - m.truncation(d - rho) / FOUR_PI;
            for _ in 0..20 {
                let q = c + random_vec(&mut rng, 1.0).clamp_length_max(1.0) * rho;
                let (v, _) = m.at(q).expect("outside the ball");
                let err = (local.eval(q) - v).abs();
                assert!(err <= taylor * (1.0 + 1e-9) + 1e-15, "{err} > {taylor}");
                tightest = tightest.max(err / taylor);
            }
        }
        assert!(tightest > 0.5, "worst error / Taylor bound {tightest}");
    }
}
