//! Mitsuba's perspective camera: the tangents of the half field of view along x and y.

use crate::scene::{Camera, FovAxis};

/// `(tan(fov_x / 2), tan(fov_y / 2))` for an image of `width` × `height` (Mitsuba's
/// `parse_fov`: the field of view is converted to the x axis, y follows the aspect ratio).
pub fn half_fov_tangents(camera: &Camera, width: u32, height: u32) -> (f32, f32) {
    let aspect = width as f32 / height as f32;
    let t = (camera.fov_degrees.to_radians() * 0.5).tan();
    let axis = match camera.fov_axis {
        FovAxis::Smaller if aspect > 1.0 => FovAxis::Y,
        FovAxis::Smaller => FovAxis::X,
        FovAxis::Larger if aspect > 1.0 => FovAxis::X,
        FovAxis::Larger => FovAxis::Y,
        other => other,
    };
    let tan_x = match axis {
        FovAxis::Y => t * aspect,
        // The diagonal's half tangent split along the image's sides.
        FovAxis::Diagonal => t / (1.0 + 1.0 / (aspect * aspect)).sqrt(),
        _ => t,
    };
    (tan_x, tan_x / aspect)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fov_axes_follow_mitsuba() {
        let mut c = Camera {
            fov_degrees: 90.0,
            ..Camera::default()
        };
        let (x, y) = half_fov_tangents(&c, 200, 100);
        assert!((x - 1.0).abs() < 1e-6 && (y - 0.5).abs() < 1e-6);
        c.fov_axis = FovAxis::Y;
        let (x, y) = half_fov_tangents(&c, 200, 100);
        assert!((x - 2.0).abs() < 1e-6 && (y - 1.0).abs() < 1e-6);
        c.fov_axis = FovAxis::Diagonal;
        let (x, y) = half_fov_tangents(&c, 200, 100);
        assert!(((x * x + y * y).sqrt() - 1.0).abs() < 1e-6);
        c.fov_axis = FovAxis::Smaller;
        assert_eq!(half_fov_tangents(&c, 200, 100), (2.0, 1.0));
    }
}
