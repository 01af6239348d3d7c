//! A pinhole or orthographic camera, shared by the triangle rasterizer
//! ([`crate::triangle::render_mesh`]) and the discrete ray caster
//! ([`crate::render`]).
//!
//! Conventions: right-handed world space; the camera looks from `eye`
//! towards `target` with `up` roughly up. Everything is `f64`: a scene far
//! from the origin (1e7 offsets) must keep its sub-voxel rays. View space is
//! Y-up, looking down −Z. The rasterizer's projection is glam's right-handed
//! DirectX/WebGPU convention (NDC `z ∈ [0, 1]`, 0 on the near plane), built
//! in `f64` and handed over as `f32` matrices. Image pixels are y **down**:
//! pixel `(i, j)` has its centre at NDC `x = 2(i + ½)/W − 1`,
//! `y = 1 − 2(j + ½)/H`.

use glam::{DMat4, DVec3, Mat4};

use crate::error::{Result, VoxkitError};

/// The projection of a [`Camera`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// Perspective with a vertical field of view in degrees, in `(0, 180)`.
    Perspective {
        /// Vertical field of view, degrees.
        fov_y_deg: f64,
    },
    /// Orthographic, showing `height` world units vertically (the width
    /// follows from the aspect ratio).
    Orthographic {
        /// Visible world height.
        height: f64,
    },
}

/// A named viewing direction (`--view`), relative to the scene's up axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, clap::ValueEnum)]
pub enum ViewPreset {
    /// Looking at the scene's front (from the front axis towards the centre).
    Front,
    /// From behind.
    Back,
    /// From the scene's left.
    Left,
    /// From the scene's right.
    Right,
    /// From above, looking down the up axis.
    Top,
    /// From below.
    Bottom,
    /// The three-quarter view: front-right and a little above (the default).
    Iso,
}

/// Which world axis is up for a scene, with the front and right axes that
/// complete the frame the [`ViewPreset`]s refer to.
///
/// Meshes (OBJ and glTF are Y-up) and the voxel grids made from them use
/// [`SceneAxes::Y_UP`]; medical volumes and MagicaVoxel files are Z-up
/// ([`SceneAxes::Z_UP`], front = −Y: the anterior side in LPS coordinates).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SceneAxes {
    /// Unit up vector.
    pub up: DVec3,
    /// Unit vector pointing from the scene towards a viewer of its front.
    pub front: DVec3,
    /// Unit vector to the scene's right, seen from the front.
    pub right: DVec3,
}

impl SceneAxes {
    /// Y up, front +Z, right +X.
    pub const Y_UP: SceneAxes = SceneAxes {
        up: DVec3::Y,
        front: DVec3::Z,
        right: DVec3::X,
    };
    /// Z up, front −Y, right +X.
    pub const Z_UP: SceneAxes = SceneAxes {
        up: DVec3::Z,
        front: DVec3::NEG_Y,
        right: DVec3::X,
    };

    /// The axes of a scalar volume's world: Z up, and the front where the
    /// volume's anatomical space puts the patient's front (`−Y` in LPS,
    /// `+Y` in RAS and LAS), so a head stands upright facing the default
    /// view. Without an anatomical space: [`SceneAxes::Z_UP`].
    ///
    /// ```
    /// use glam::DVec3;
    /// use voxkit::camera::SceneAxes;
    /// use voxkit::grid::AnatomicalSpace;
    /// assert_eq!(SceneAxes::for_volume(None), SceneAxes::Z_UP);
    /// assert_eq!(SceneAxes::for_volume(Some(AnatomicalSpace::Lps)), SceneAxes::Z_UP);
    /// let ras = SceneAxes::for_volume(Some(AnatomicalSpace::Ras));
    /// assert_eq!((ras.front, ras.right), (DVec3::Y, DVec3::NEG_X));
    /// ```
    pub fn for_volume(space: Option<crate::grid::AnatomicalSpace>) -> SceneAxes {
        let front = DVec3::new(0.0, space.map_or(-1.0, |s| s.anterior_y()), 0.0);
        // The viewer's right, facing the front: up × front (a rotation of
        // Z_UP, never a mirror).
        SceneAxes {
            up: DVec3::Z,
            front,
            right: DVec3::Z.cross(front),
        }
    }

    /// Unit direction from the scene towards the eye for a preset, and the
    /// camera up vector to use with it.
    pub fn view(&self, preset: ViewPreset) -> (DVec3, DVec3) {
        let (u, f, r) = (self.up, self.front, self.right);
        match preset {
            ViewPreset::Front => (f, u),
            ViewPreset::Back => (-f, u),
            ViewPreset::Left => (-r, u),
            ViewPreset::Right => (r, u),
            // Looking down the up axis the picture's up is the scene's back.
            ViewPreset::Top => (u, -f),
            ViewPreset::Bottom => (-u, f),
            ViewPreset::Iso => ((f * 0.8 + r * 0.6 + u * 0.45).normalize(), u),
        }
    }
}

/// A camera: position, orientation, projection and clip distances.
///
/// ```
/// use glam::DVec3;
/// use voxkit::camera::Camera;
/// let cam = Camera::perspective(DVec3::new(0.0, 0.0, 5.0), DVec3::ZERO, DVec3::Y, 60.0);
/// cam.validate().unwrap();
/// // The ray through the image centre points at the target.
/// let (o, d) = cam.primary_ray(50.0, 50.0, 100, 100);
/// assert!((o - DVec3::new(0.0, 0.0, 5.0)).length() < 1e-12);
/// assert!((d - DVec3::new(0.0, 0.0, -1.0)).length() < 1e-12);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Camera position.
    pub eye: DVec3,
    /// Point looked at.
    pub target: DVec3,
    /// Up direction (need not be unit or orthogonal to the view direction,
    /// but must not be parallel to it).
    pub up: DVec3,
    /// Projection.
    pub projection: Projection,
    /// Near clip distance (> 0), used by the rasterizer.
    pub near: f64,
    /// Far clip distance (> near), used by the rasterizer.
    pub far: f64,
}

impl Camera {
    /// A perspective camera with clip distances 0.01 and 1000 (see
    /// [`Camera::fit_clip`] to fit them to a scene).
    pub fn perspective(eye: DVec3, target: DVec3, up: DVec3, fov_y_deg: f64) -> Self {
        Camera {
            eye,
            target,
            up,
            projection: Projection::Perspective { fov_y_deg },
            near: 0.01,
            far: 1000.0,
        }
    }

    /// An orthographic camera showing `height` world units vertically.
    pub fn orthographic(eye: DVec3, target: DVec3, up: DVec3, height: f64) -> Self {
        Camera {
            eye,
            target,
            up,
            projection: Projection::Orthographic { height },
            near: 0.01,
            far: 1000.0,
        }
    }

    /// A camera looking at the box `[min, max]` from direction `toward_eye`
    /// (from the box centre to the eye; need not be unit) with up vector
    /// `up`, placed so that the whole box fits a `width × height` image
    /// with a 5% margin: perspective with vertical field of view `fov_y_deg`,
    /// or orthographic if `fov_y_deg` is `None`. Clip distances fit the box.
    ///
    /// ```
    /// use glam::DVec3;
    /// use voxkit::camera::Camera;
    /// let cam = Camera::framing(DVec3::ZERO, DVec3::ONE, DVec3::new(1.0, 1.0, 1.0), DVec3::Y, Some(40.0), 64, 64).unwrap();
    /// cam.validate().unwrap();
    /// assert!((cam.target - DVec3::splat(0.5)).length() < 1e-12);
    /// // A box that vanishes beside its distance from the origin leaves no
    /// // room in `f64` for a camera: refused, with the cause.
    /// let far = DVec3::splat(1e6);
    /// let err = Camera::framing(far, far + 1e-30, DVec3::X, DVec3::Y, Some(40.0), 64, 64).unwrap_err();
    /// assert!(err.to_string().contains("too small beside its distance from the origin"));
    /// ```
    pub fn framing(
        min: DVec3,
        max: DVec3,
        toward_eye: DVec3,
        up: DVec3,
        fov_y_deg: Option<f64>,
        width: u32,
        height: u32,
    ) -> Result<Self> {
        if !(min.is_finite() && max.is_finite() && min.cmple(max).all()) {
            return Err(VoxkitError::invalid(format!(
                "camera framing: bad box {} .. {}",
                crate::error::shown(min),
                crate::error::shown(max)
            )));
        }
        if width == 0 || height == 0 {
            return Err(VoxkitError::invalid("camera framing: zero image size"));
        }
        let dir = toward_eye.normalize_or_zero();
        if dir == DVec3::ZERO || !dir.is_finite() {
            return Err(VoxkitError::invalid("camera framing: zero view direction"));
        }
        if dir.cross(up).length_squared() < 1e-18 {
            return Err(VoxkitError::invalid(
                "camera framing: up is zero or parallel to the view direction",
            ));
        }
        let centre = (min + max) * 0.5;
        // Box corners in the camera basis (x right, y up, z towards the eye).
        let f = -dir;
        let r = f.cross(up).normalize();
        let u = r.cross(f);
        let aspect = width as f64 / height as f64;
        let corners = (0..8).map(|i| {
            let c = DVec3::new(
                if i & 1 == 0 { min.x } else { max.x },
                if i & 2 == 0 { min.y } else { max.y },
                if i & 4 == 0 { min.z } else { max.z },
            ) - centre;
            (c.dot(r), c.dot(u), c.dot(dir))
        });
        let extent = (max - min).length().max(f64::MIN_POSITIVE);
        let margin = 1.05;
        let mut cam = match fov_y_deg {
            Some(fov) => {
                let tv = (fov.to_radians() * 0.5).tan();
                let th = tv * aspect;
                if !(tv.is_finite() && tv > 0.0) {
                    return Err(VoxkitError::invalid(
                        "camera framing: vertical field of view must be in (0, 180) degrees",
                    ));
                }
                // Distance d such that every corner (x, y, z) projects inside
                // the frustum: |x| ≤ (d − z)·tan_h, |y| ≤ (d − z)·tan_v.
                let d = corners
                    .map(|(x, y, z)| (z + x.abs() * margin / th).max(z + y.abs() * margin / tv))
                    .fold(0.0f64, f64::max)
                    .max(extent * 1e-6);
                Camera::perspective(centre + dir * d, centre, up, fov)
            }
            None => {
                let (mut hx, mut hy, mut hz) = (0.0f64, 0.0f64, 0.0f64);
                for (x, y, z) in corners {
                    hx = hx.max(x.abs());
                    hy = hy.max(y.abs());
                    hz = hz.max(z.abs());
                }
                let h = (2.0 * hy).max(2.0 * hx / aspect) * margin;
                let h = h.max(extent * 1e-6);
                Camera::orthographic(centre + dir * (hz + extent * 0.05), centre, up, h)
            }
        };
        cam.fit_clip(min, max);
        // A box whose extent vanishes beside its distance from the origin
        // (a spacing of 1e-30 at 1e6) leaves no room in `f64` between the
        // eye and the target: say so, not only that the eye is the target.
        if (cam.target - cam.eye).length_squared() == 0.0 {
            return Err(VoxkitError::invalid(format!(
                "camera framing: the box {} .. {} (extent {:e}) is too small beside its \
                 distance from the origin for double precision to place a camera; scale its \
                 spacing up or move its origin nearer",
                crate::error::shown(min),
                crate::error::shown(max),
                (max - min).length()
            )));
        }
        Ok(cam)
    }

    /// Checks that the camera is usable: finite values, `eye ≠ target`,
    /// `up` not parallel to the view direction, `0 < near < far`, a field
    /// of view in `(0, 180)` degrees or a positive orthographic height.
    pub fn validate(&self) -> Result<()> {
        let bad = |m: &str| Err(VoxkitError::invalid(format!("camera: {m}")));
        if !(self.eye.is_finite() && self.target.is_finite() && self.up.is_finite()) {
            return bad("non-finite eye, target or up");
        }
        let f = self.target - self.eye;
        if f.length_squared() == 0.0 {
            return bad("eye equals target");
        }
        if f.normalize().cross(self.up).length_squared() < 1e-18 {
            return bad("up is zero or parallel to the view direction");
        }
        if !(self.near > 0.0 && self.far > self.near && self.far.is_finite()) {
            return bad("need 0 < near < far < ∞");
        }
        match self.projection {
            Projection::Perspective { fov_y_deg } if !(fov_y_deg > 0.0 && fov_y_deg < 180.0) => {
                bad("vertical field of view must be in (0, 180) degrees")
            }
            Projection::Orthographic { height } if !(height > 0.0 && height.is_finite()) => {
                bad("orthographic height must be positive")
            }
            _ => Ok(()),
        }
    }

    /// Unit view direction.
    pub fn forward(&self) -> DVec3 {
        (self.target - self.eye).normalize()
    }

    /// The orthonormal camera basis `(right, up, forward)`.
    pub fn basis(&self) -> (DVec3, DVec3, DVec3) {
        let f = self.forward();
        let r = f.cross(self.up).normalize();
        (r, r.cross(f), f)
    }

    /// World → view matrix (right-handed, looking down −Z), in `f32` for the
    /// rasterizer.
    pub fn view_matrix(&self) -> Mat4 {
        let (_, u, f) = self.basis();
        glam::dcamera::rh::view::look_to_mat4(self.eye, f, u).as_mat4()
    }

    /// View → clip matrix for an image of the given aspect ratio
    /// (width / height).
    pub fn projection_matrix(&self, aspect: f64) -> Mat4 {
        self.projection_dmat4(aspect).as_mat4()
    }

    fn projection_dmat4(&self, aspect: f64) -> DMat4 {
        use glam::dcamera::rh::proj::directx;
        match self.projection {
            Projection::Perspective { fov_y_deg } => {
                directx::perspective(fov_y_deg.to_radians(), aspect, self.near, self.far)
            }
            Projection::Orthographic { height } => {
                let (hh, hw) = (height * 0.5, height * 0.5 * aspect);
                directx::orthographic(-hw, hw, -hh, hh, self.near, self.far)
            }
        }
    }

    /// World → clip matrix for a `width × height` image (composed in `f64`).
    pub fn view_projection(&self, width: u32, height: u32) -> Mat4 {
        let (_, u, f) = self.basis();
        let view = glam::dcamera::rh::view::look_to_mat4(self.eye, f, u);
        (self.projection_dmat4(width as f64 / height as f64) * view).as_mat4()
    }

    /// Moves `near` and `far` to enclose the box `[min, max]` (with a small
    /// margin); `near` stays at least `far · 1e-5`.
    pub fn fit_clip(&mut self, min: DVec3, max: DVec3) {
        let f = self.forward();
        let mut lo = f64::INFINITY;
        let mut hi = f64::NEG_INFINITY;
        for i in 0..8 {
            let c = DVec3::new(
                if i & 1 == 0 { min.x } else { max.x },
                if i & 2 == 0 { min.y } else { max.y },
                if i & 4 == 0 { min.z } else { max.z },
            );
            let d = (c - self.eye).dot(f);
            lo = lo.min(d);
            hi = hi.max(d);
        }
        let far = (hi.abs() * 1.01).max(1e-3);
        self.far = far;
        self.near = (lo * 0.99).max(far * 1e-5);
    }

    /// The direction through image position `(px, py)` (pixels, y down;
    /// pixel `(i, j)` has its centre at `(i + ½, j + ½)`), not normalised,
    /// with unit component along the view direction; and for orthographic
    /// cameras the offset of the ray's origin from `eye` in the image plane.
    fn through(&self, px: f64, py: f64, width: u32, height: u32) -> (DVec3, DVec3) {
        let (r, u, f) = self.basis();
        let aspect = width as f64 / height as f64;
        let nx = 2.0 * px / width as f64 - 1.0;
        let ny = 1.0 - 2.0 * py / height as f64;
        match self.projection {
            Projection::Perspective { fov_y_deg } => {
                let t = (fov_y_deg.to_radians() * 0.5).tan();
                (f + r * (nx * t * aspect) + u * (ny * t), DVec3::ZERO)
            }
            Projection::Orthographic { height } => {
                let (hh, hw) = (height * 0.5, height * 0.5 * aspect);
                (f, r * (nx * hw) + u * (ny * hh))
            }
        }
    }

    /// The ray through image position `(px, py)` (see [`Camera::primary_ray`]
    /// for the pixel convention) starting on the **near plane**, with unit
    /// direction: what the rasterizer clips against.
    pub fn pixel_ray(&self, px: f64, py: f64, width: u32, height: u32) -> (DVec3, DVec3) {
        let (d, offset) = self.through(px, py, width, height);
        // `d` has unit forward component, so `eye + offset + near·d` is on the
        // near plane.
        (self.eye + offset + d * self.near, d.normalize())
    }

    /// The ray the ray caster casts through image position `(px, py)`
    /// (pixels, y down; pixel `(i, j)` has its centre at `(i + ½, j + ½)`):
    /// origin at `eye` for a perspective camera, in the plane through `eye`
    /// perpendicular to the view direction for an orthographic one; unit
    /// direction. Built from the camera basis in `f64`.
    pub fn primary_ray(&self, px: f64, py: f64, width: u32, height: u32) -> (DVec3, DVec3) {
        let (d, offset) = self.through(px, py, width, height);
        (self.eye + offset, d.normalize())
    }

    /// The camera turned by `angle` radians about the axis through `target`
    /// along `axis` (for turntables).
    pub fn orbited(&self, axis: DVec3, angle: f64) -> Camera {
        let q = glam::DQuat::from_axis_angle(axis.normalize(), angle);
        Camera {
            eye: self.target + q * (self.eye - self.target),
            up: q * self.up,
            ..*self
        }
    }
}
