//! A pinhole or orthographic camera shared by the triangle renderer and the
//! ray caster.
//!
//! Conventions: right-handed world space; the camera looks from `eye`
//! towards `target` with `up` roughly up. View space is Y-up, looking down
//! −Z. Projection is glam's right-handed DirectX/WebGPU convention (NDC
//! `z ∈ [0, 1]`, 0 on the near plane, 1 on the far plane). Image pixels are
//! y **down**: pixel `(i, j)` has its centre at NDC
//! `x = 2(i + ½)/W − 1`, `y = 1 − 2(j + ½)/H`.

use glam::{Mat4, Vec3};

use crate::error::{Result, VoxkitError};

/// The projection of a [`Camera`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// Perspective with a vertical field of view in degrees, in `(0, 180)`.
    Perspective {
        /// Vertical field of view, degrees.
        fov_y_deg: f32,
    },
    /// Orthographic, showing `height` world units vertically (the width
    /// follows from the aspect ratio).
    Orthographic {
        /// Visible world height.
        height: f32,
    },
}

/// A camera: position, orientation, projection and clip distances.
///
/// ```
/// use glam::Vec3;
/// use voxkit::triangle::Camera;
/// let cam = Camera::perspective(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y, 60.0);
/// cam.validate().unwrap();
/// // The ray through the image centre points at the target.
/// let (o, d) = cam.pixel_ray(50.0, 50.0, 100, 100);
/// assert!((o - Vec3::new(0.0, 0.0, 5.0 - cam.near)).length() < 1e-4);
/// assert!((d - Vec3::new(0.0, 0.0, -1.0)).length() < 1e-5);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Camera position.
    pub eye: Vec3,
    /// Point looked at.
    pub target: Vec3,
    /// Up direction (need not be unit or orthogonal to the view direction,
    /// but must not be parallel to it).
    pub up: Vec3,
    /// Projection.
    pub projection: Projection,
    /// Near clip distance (> 0).
    pub near: f32,
    /// Far clip distance (> near).
    pub far: f32,
}

impl Camera {
    /// A perspective camera with clip distances 0.01 and 1000 (see
    /// [`Camera::fit_clip`] to fit them to a scene).
    pub fn perspective(eye: Vec3, target: Vec3, up: Vec3, fov_y_deg: f32) -> Self {
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
    pub fn orthographic(eye: Vec3, target: Vec3, up: Vec3, height: f32) -> Self {
        Camera {
            eye,
            target,
            up,
            projection: Projection::Orthographic { height },
            near: 0.01,
            far: 1000.0,
        }
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
        if f.normalize().cross(self.up).length_squared() < 1e-12 {
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
    pub fn forward(&self) -> Vec3 {
        (self.target - self.eye).normalize()
    }

    /// World → view matrix (right-handed, looking down −Z).
    pub fn view_matrix(&self) -> Mat4 {
        let f = self.forward();
        let r = f.cross(self.up).normalize();
        let u = r.cross(f);
        glam::camera::rh::view::look_to_mat4(self.eye, f, u)
    }

    /// View → clip matrix for an image of the given aspect ratio
    /// (width / height).
    pub fn projection_matrix(&self, aspect: f32) -> Mat4 {
        use glam::camera::rh::proj::directx;
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

    /// World → clip matrix for a `width × height` image.
    pub fn view_projection(&self, width: u32, height: u32) -> Mat4 {
        self.projection_matrix(width as f32 / height as f32) * self.view_matrix()
    }

    /// Moves `near` and `far` to enclose the box `[min, max]` (with a small
    /// margin); `near` stays at least `far · 1e-5`.
    pub fn fit_clip(&mut self, min: Vec3, max: Vec3) {
        let f = self.forward();
        let mut lo = f32::INFINITY;
        let mut hi = f32::NEG_INFINITY;
        for i in 0..8 {
            let c = Vec3::new(
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

    /// The ray through image position `(px, py)` (pixels, y down; pixel
    /// `(i, j)` has its centre at `(i + ½, j + ½)`): origin on the near plane
    /// and unit direction. For a perspective camera the ray passes through
    /// `eye`; for an orthographic one all rays are parallel to the view
    /// direction.
    pub fn pixel_ray(&self, px: f32, py: f32, width: u32, height: u32) -> (Vec3, Vec3) {
        // Built from the camera basis rather than by inverting the
        // view-projection matrix, which loses precision when far/near is
        // large.
        let f = self.forward();
        let r = f.cross(self.up).normalize();
        let u = r.cross(f);
        let aspect = width as f32 / height as f32;
        let nx = 2.0 * px / width as f32 - 1.0;
        let ny = 1.0 - 2.0 * py / height as f32;
        match self.projection {
            Projection::Perspective { fov_y_deg } => {
                let t = (fov_y_deg.to_radians() * 0.5).tan();
                let d = f + r * (nx * t * aspect) + u * (ny * t);
                // `d` has unit forward component, so `eye + near·d` is on the
                // near plane.
                (self.eye + d * self.near, d.normalize())
            }
            Projection::Orthographic { height } => {
                let (hh, hw) = (height * 0.5, height * 0.5 * aspect);
                let o = self.eye + r * (nx * hw) + u * (ny * hh) + f * self.near;
                (o, f)
            }
        }
    }
}
