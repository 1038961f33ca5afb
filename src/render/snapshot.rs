//! What the renderer draws: a plain copy of the field made by whoever sampled the simulation.
//! The renderer only reads it.

use bytemuck::{Pod, Zeroable};
use glam::DVec2;

use super::layout::Layout;
use crate::physics::{BallKind, Bodies, Field};
use crate::runtime::BallRecord;

/// Style of a ball, in the top byte of [`BallSprite::colour`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BallStyle {
    Plain = 0,
    /// The key ball: a white ring.
    Key = 1,
    /// A ball the mouse holds: a yellow ring.
    Held = 2,
}

/// One ball as the GPU gets it: 16 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct BallSprite {
    /// Centre, m.
    pub x: f32,
    pub y: f32,
    /// Radius, m.
    pub radius: f32,
    /// `0xSSBBGGRR`: RGB in sRGB and the [`BallStyle`] in the top byte.
    pub colour: u32,
}

/// A thick line segment (overlays, field, walls): 28 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Segment {
    /// `[x0, y0, x1, y1]`, m.
    pub ends: [f32; 4],
    /// Half the thickness: `[metres, pixels]`, added. The ends are extended by the pixel part.
    pub half_width: [f32; 2],
    /// `0xAABBGGRR`, RGB in sRGB, straight alpha.
    pub colour: u32,
}

impl Segment {
    pub fn line(a: DVec2, b: DVec2, half_width_px: f32, colour: u32) -> Segment {
        Segment { ends: [a.x as f32, a.y as f32, b.x as f32, b.y as f32], half_width: [0.0, half_width_px], colour }
    }
}

/// Packs an sRGB colour and alpha as `0xAABBGGRR` (the byte order `unpack4x8unorm` reads).
pub const fn rgba(r: u8, g: u8, b: u8, a: u8) -> u32 {
    (r as u32) | ((g as u32) << 8) | ((b as u32) << 16) | ((a as u32) << 24)
}

/// Colours of the picture.
pub mod palette {
    use super::rgba;
    /// Around the field (the letterbox).
    pub const OUTSIDE_PACKED: u32 = rgba(14, 15, 19, 255);
    /// The field (the target is cleared to it), as 0–1 sRGB values.
    pub const FIELD_RGB: [f64; 3] = [24.0 / 255.0, 28.0 / 255.0, 38.0 / 255.0];
    pub const WALL: u32 = rgba(150, 158, 176, 255);
    pub const KEY_BALL: u32 = rgba(235, 82, 52, 255);
    /// Plain balls take one of these, by id.
    pub const BALLS: [u32; 6] = [
        rgba(72, 149, 239, 255),
        rgba(86, 196, 160, 255),
        rgba(122, 128, 230, 255),
        rgba(64, 186, 214, 255),
        rgba(150, 200, 90, 255),
        rgba(170, 120, 220, 255),
    ];
    pub const VELOCITY: u32 = rgba(255, 225, 120, 220);
    pub const CENTRE_OF_MASS: u32 = rgba(255, 90, 200, 255);
    pub const TRACE: u32 = rgba(235, 82, 52, 150);
    pub const PULL: u32 = rgba(255, 255, 255, 230);
}

/// The colour of a ball of kind `kind` and id `id`, with its style.
pub fn ball_colour(kind: BallKind, id: u32) -> u32 {
    match kind {
        BallKind::Key => (palette::KEY_BALL & 0x00FF_FFFF) | ((BallStyle::Key as u32) << 24),
        // Knuth's multiplicative hash spreads neighbouring ids over the palette.
        BallKind::Ball => {
            let k = (id.wrapping_mul(2_654_435_761) >> 16) as usize % palette::BALLS.len();
            (palette::BALLS[k] & 0x00FF_FFFF) | ((BallStyle::Plain as u32) << 24)
        }
    }
}

/// Sets the style byte of a packed ball colour.
pub fn with_style(colour: u32, style: BallStyle) -> u32 {
    (colour & 0x00FF_FFFF) | ((style as u32) << 24)
}

/// A frame's worth of the field, ready to draw. Reuse one and refill it every frame: its vectors
/// keep their memory.
#[derive(Clone, Debug, Default)]
pub struct FrameSnapshot {
    pub field: Field,
    pub balls: Vec<BallSprite>,
    /// Drawn over the balls.
    pub overlays: Vec<Segment>,
    /// The part of the target to fit the field into, `[x, y, w, h]` in pixels from the top-left;
    /// `None` = all of it.
    pub viewport: Option<[f64; 4]>,
}

impl FrameSnapshot {
    /// Where this snapshot lands on a `width × height` target.
    pub fn layout(&self, width: u32, height: u32) -> Layout {
        match self.viewport {
            Some(v) => Layout::fit_in(&self.field, width, height, v),
            None => Layout::fit(&self.field, width, height),
        }
    }

    pub fn new(field: Field) -> Self {
        FrameSnapshot { field, ..Default::default() }
    }

    /// Refills the balls from a lockstep engine's bodies (in their order). Overlays are cleared.
    pub fn fill_from_bodies(&mut self, field: Field, bodies: &Bodies) {
        self.field = field;
        self.balls.clear();
        self.overlays.clear();
        self.balls.extend((0..bodies.len()).map(|i| BallSprite {
            x: bodies.position[i].x as f32,
            y: bodies.position[i].y as f32,
            radius: bodies.radius[i] as f32,
            colour: ball_colour(bodies.kind[i], bodies.id[i].0),
        }));
        self.key_last();
    }

    /// Refills the balls from the threaded runtime's table. Overlays are cleared.
    pub fn fill_from_records(&mut self, field: Field, records: &[BallRecord]) {
        self.field = field;
        self.balls.clear();
        self.overlays.clear();
        self.balls.extend(records.iter().map(|r| BallSprite {
            x: r.ball.position.x as f32,
            y: r.ball.position.y as f32,
            radius: r.ball.radius() as f32,
            colour: ball_colour(r.ball.kind, r.ball.id.0),
        }));
        self.key_last();
    }

    /// The key ball is drawn last, over any ball it overlaps.
    fn key_last(&mut self) {
        let key = (BallStyle::Key as u32) << 24;
        if let Some(k) = self.balls.iter().position(|b| b.colour & 0xFF00_0000 == key) {
            let last = self.balls.len() - 1;
            self.balls.swap(k, last);
        }
    }
}

/// Overlays: segments to push onto [`FrameSnapshot::overlays`].
impl FrameSnapshot {
    /// An arrow from each ball's centre along its velocity, `seconds` of travel long.
    pub fn add_velocity_vectors(&mut self, balls: impl IntoIterator<Item = (DVec2, DVec2)>, seconds: f64) {
        for (p, v) in balls {
            if v.length_squared() > 1e-12 {
                self.overlays.push(Segment::line(p, p + v * seconds, 1.0, palette::VELOCITY));
            }
        }
    }

    /// A cross of `size` metres at `p`.
    pub fn add_cross(&mut self, p: DVec2, size: f64, colour: u32) {
        let (dx, dy) = (DVec2::new(size, 0.0), DVec2::new(0.0, size));
        self.overlays.push(Segment::line(p - dx, p + dx, 1.5, colour));
        self.overlays.push(Segment::line(p - dy, p + dy, 1.5, colour));
    }

    /// A polyline through `points`, fading in from its first point (the oldest) to its last.
    pub fn add_trace(&mut self, points: &[DVec2], colour: u32) {
        let n = points.len();
        let alpha = (colour >> 24) as f64;
        for (k, pair) in points.windows(2).enumerate() {
            let a = (alpha * (k + 1) as f64 / n as f64) as u32;
            self.overlays.push(Segment::line(pair[0], pair[1], 1.0, (colour & 0x00FF_FFFF) | (a << 24)));
        }
    }
}
