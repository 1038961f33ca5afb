//! Where the field lands on a target: metres to pixels, the aspect ratio kept (letterbox).

use glam::DVec2;

use crate::physics::Field;

/// Pixels per metre at the default size.
pub const PIXELS_PER_METRE: f64 = 10.0;

/// Pixels left around the field on each side at any size: room for the walls.
pub const MARGIN_PX: f64 = 10.0;

/// The mapping from field metres to target pixels.
///
/// Pixel coordinates here have their origin at the target's top-left corner and y pointing down
/// (as winit's cursor and egui have them); the field has its origin at the lower-left corner and
/// y pointing up.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Layout {
    /// Pixels per metre.
    pub scale: f64,
    /// Pixel position (from the top-left corner) of the field's lower-left corner.
    pub origin: DVec2,
    /// The whole target's width, pixels (not the viewport's).
    pub width: u32,
    /// The whole target's height, pixels (not the viewport's): the shaders, whose pixels count
    /// from the bottom, get the origin flipped with it.
    pub height: u32,
}

impl Layout {
    /// The largest scale at which the field and its walls fit in `width × height`, centred.
    pub fn fit(field: &Field, width: u32, height: u32) -> Layout {
        Self::fit_in(field, width, height, [0.0, 0.0, width as f64, height as f64])
    }

    /// The same inside the part `[x, y, w, h]` (pixels from the top-left) of a `width × height`
    /// target: the window leaves room for its panel this way.
    pub fn fit_in(field: &Field, width: u32, height: u32, viewport: [f64; 4]) -> Layout {
        let [x, y, w, h] = viewport;
        let sx = (w - 2.0 * MARGIN_PX) / field.width;
        let sy = (h - 2.0 * MARGIN_PX) / field.height;
        // A target smaller than the margins still gets a (tiny) positive scale.
        let scale = sx.min(sy).max(1e-3);
        let left = x + 0.5 * (w - field.width * scale);
        let top = y + 0.5 * (h - field.height * scale);
        Layout { scale, origin: DVec2::new(left, top + field.height * scale), width, height }
    }

    /// The target size at which the field is drawn at [`PIXELS_PER_METRE`].
    pub fn default_size(field: &Field) -> (u32, u32) {
        let w = (field.width * PIXELS_PER_METRE + 2.0 * MARGIN_PX).round();
        let h = (field.height * PIXELS_PER_METRE + 2.0 * MARGIN_PX).round();
        (w.clamp(16.0, 8192.0) as u32, h.clamp(16.0, 8192.0) as u32)
    }

    /// Field metres to target pixels (top-left origin, y down).
    pub fn to_pixels(&self, p: DVec2) -> DVec2 {
        DVec2::new(self.origin.x + p.x * self.scale, self.origin.y - p.y * self.scale)
    }

    /// Target pixels (top-left origin, y down) to field metres.
    pub fn to_metres(&self, px: DVec2) -> DVec2 {
        DVec2::new((px.x - self.origin.x) / self.scale, (self.origin.y - px.y) / self.scale)
    }

    /// The field's lower-left corner in the shaders' convention: pixels from the bottom-left.
    pub(crate) fn origin_from_bottom(&self) -> [f32; 2] {
        [self.origin.x as f32, (self.height as f64 - self.origin.y) as f32]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_size_is_ten_pixels_per_metre() {
        let field = Field::default();
        assert_eq!(Layout::default_size(&field), (720, 520));
        let l = Layout::fit(&field, 720, 520);
        assert_eq!(l.scale, 10.0);
        assert_eq!(l.to_pixels(DVec2::ZERO), DVec2::new(10.0, 510.0));
        assert_eq!(l.to_pixels(DVec2::new(70.0, 50.0)), DVec2::new(710.0, 10.0));
    }

    #[test]
    fn letterbox_keeps_aspect_and_round_trips() {
        let field = Field::default();
        let l = Layout::fit(&field, 1280, 720);
        assert_eq!(l.scale, 14.0); // (720 - 20) / 50, the height limits
        let p = DVec2::new(12.5, 40.0);
        assert!((l.to_metres(l.to_pixels(p)) - p).length() < 1e-9);
        // centred horizontally
        let left = l.to_pixels(DVec2::ZERO).x;
        let right = 1280.0 - l.to_pixels(DVec2::new(70.0, 0.0)).x;
        assert!((left - right).abs() < 1e-9);
    }
}
