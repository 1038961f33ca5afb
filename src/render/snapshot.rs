//! What the renderer draws: a plain copy of the field made by whoever sampled the simulation.
//! The renderer only reads it.

use std::borrow::Borrow;

use bytemuck::{Pod, Zeroable};
use glam::DVec2;

use super::layout::Layout;
use crate::physics::{Ball, BallKind, Field};

/// Style of a ball, in the top byte of [`BallSprite::colour`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BallStyle {
    /// An ordinary ball: its colour, with a rim about 1.5 px wide darkened by up to 35 % so that
    /// touching balls stay apart.
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
    /// Centre's x, m from the field's left wall.
    pub x: f32,
    /// Centre's y, m from the field's floor (y up).
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

impl BallSprite {
    /// How `ball` is drawn: where, how large, in its kind's and id's colour.
    pub fn of(ball: &Ball) -> BallSprite {
        BallSprite {
            x: ball.position.x as f32,
            y: ball.position.y as f32,
            radius: ball.radius() as f32,
            colour: ball_colour(ball.kind, ball.id.0),
        }
    }
}

impl Segment {
    /// A segment from `a` to `b` (field metres) `2 × half_width_px` pixels thick at any scale,
    /// its ends extended by `half_width_px`; `colour` as [`Segment::colour`].
    pub fn line(a: DVec2, b: DVec2, half_width_px: f32, colour: u32) -> Segment {
        Segment { ends: [a.x as f32, a.y as f32, b.x as f32, b.y as f32], half_width: [0.0, half_width_px], colour }
    }
}

/// Packs an sRGB colour and alpha as `0xAABBGGRR` (the byte order `unpack4x8unorm` reads).
pub const fn rgba(r: u8, g: u8, b: u8, a: u8) -> u32 {
    (r as u32) | ((g as u32) << 8) | ((b as u32) << 16) | ((a as u32) << 24)
}

/// Colours of the picture: sRGB levels 0–255 and straight alpha packed by [`rgba`]
/// (`0xAABBGGRR`), except [`FIELD_RGB`](palette::FIELD_RGB).
pub mod palette {
    use super::rgba;
    /// Around the field (the letterbox).
    pub const OUTSIDE_PACKED: u32 = rgba(14, 15, 19, 255);
    /// The field (the target is cleared to it), as 0–1 sRGB values.
    pub const FIELD_RGB: [f64; 3] = [24.0 / 255.0, 28.0 / 255.0, 38.0 / 255.0];
    /// The walls around the field.
    pub const WALL: u32 = rgba(150, 158, 176, 255);
    /// The key ball (the one the user steers), under its white ring.
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
    /// The velocity arrows ([`add_velocity_vectors`](super::FrameSnapshot::add_velocity_vectors)),
    /// slightly translucent.
    pub const VELOCITY: u32 = rgba(255, 225, 120, 220);
    /// The centre-of-mass cross ([`add_centre_of_mass`](super::FrameSnapshot::add_centre_of_mass)).
    pub const CENTRE_OF_MASS: u32 = rgba(255, 90, 200, 255);
    /// A trace ([`add_trace`](super::FrameSnapshot::add_trace)): the key ball's red; it fades
    /// from about this alpha at its newest point to nearly 0 at its oldest.
    pub const TRACE: u32 = rgba(235, 82, 52, 150);
    /// The pull on the key ball ([`add_pull`](super::FrameSnapshot::add_pull)).
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
    /// The field drawn: its size places it on the target and puts the walls around it.
    pub field: Field,
    /// The balls, drawn in this order (later ones over earlier ones).
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

    /// An empty snapshot of `field`: no balls, no overlays, the whole target.
    pub fn new(field: Field) -> Self {
        FrameSnapshot { field, ..Default::default() }
    }

    /// Refills the balls from `balls`, whoever sampled them (a lockstep engine's bodies, the
    /// threaded runtime's table, the window's copy), and clears the overlays.
    ///
    /// The balls are drawn in their order, except the key ball: it is drawn after all of them,
    /// over any ball it overlaps, because it is the one the user steers and must never be hidden.
    /// The others keep their relative order (a stable move, not a swap), so two runs that sample
    /// the same balls in the same order draw the same picture.
    pub fn fill<B: Borrow<Ball>>(&mut self, field: Field, balls: impl IntoIterator<Item = B>) {
        self.field = field;
        self.balls.clear();
        self.overlays.clear();
        self.balls.extend(balls.into_iter().map(|b| BallSprite::of(b.borrow())));
        let key = (BallStyle::Key as u32) << 24;
        if let Some(k) = self.balls.iter().position(|b| b.colour & 0xFF00_0000 == key) {
            self.balls[k..].rotate_left(1);
        }
    }

    /// A ball the mouse holds, at `position` (where the cursor is, not where the engine last saw
    /// it): drawn over every ball of the field, the key ball included, with a yellow ring.
    pub fn add_held(&mut self, ball: &Ball, position: DVec2) {
        let sprite = BallSprite::of(&Ball { position, ..*ball });
        self.balls.push(BallSprite { colour: with_style(sprite.colour, BallStyle::Held), ..sprite });
    }
}

/// Overlays: segments to push onto [`FrameSnapshot::overlays`].
impl FrameSnapshot {
    /// An arrow from each ball's centre along its velocity, `seconds` of travel long.
    pub fn add_velocity_vectors<B: Borrow<Ball>>(&mut self, balls: impl IntoIterator<Item = B>, seconds: f64) {
        for b in balls {
            let (p, v) = (b.borrow().position, b.borrow().velocity);
            if v.length_squared() > 1e-12 {
                self.overlays.push(Segment::line(p, p + v * seconds, 1.0, palette::VELOCITY));
            }
        }
    }

    /// A cross of 1.5 m at the centre of mass of `balls` (nothing for no balls, or no mass).
    pub fn add_centre_of_mass<B: Borrow<Ball>>(&mut self, balls: impl IntoIterator<Item = B>) {
        let (mut mass, mut moment) = (0.0, DVec2::ZERO);
        for b in balls {
            let b = b.borrow();
            mass += b.mass;
            moment += b.position * b.mass;
        }
        if mass > 0.0 {
            self.add_cross(moment / mass, 1.5, palette::CENTRE_OF_MASS);
        }
    }

    /// The pull on the key ball at `from`: a white line along `force`, 1 m per 100 N.
    pub fn add_pull(&mut self, from: DVec2, force: DVec2) {
        if force != DVec2::ZERO {
            self.overlays.push(Segment::line(from, from + force / 100.0, 2.0, palette::PULL));
        }
    }

    /// A cross of `size` metres at `p`.
    pub fn add_cross(&mut self, p: DVec2, size: f64, colour: u32) {
        let (dx, dy) = (DVec2::new(size, 0.0), DVec2::new(0.0, size));
        self.overlays.push(Segment::line(p - dx, p + dx, 1.5, colour));
        self.overlays.push(Segment::line(p - dy, p + dy, 1.5, colour));
    }

    /// A polyline through `points`, fading in from its first point (the oldest) to its last.
    pub fn add_trace<I>(&mut self, points: I, colour: u32)
    where
        I: IntoIterator<Item = DVec2>,
        I::IntoIter: ExactSizeIterator,
    {
        let mut points = points.into_iter();
        let n = points.len();
        let alpha = (colour >> 24) as f64;
        let Some(mut last) = points.next() else { return };
        for (k, p) in points.enumerate() {
            let a = (alpha * (k + 1) as f64 / n as f64) as u32;
            self.overlays.push(Segment::line(last, p, 1.0, (colour & 0x00FF_FFFF) | (a << 24)));
            last = p;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::BallId;

    fn ball(id: u32, kind: BallKind, x: f64) -> Ball {
        Ball {
            id: BallId(id),
            kind,
            position: DVec2::new(x, 1.0),
            velocity: DVec2::new(1.0, 0.0),
            mass: 1.0 + id as f64,
            diameter: 1.0,
        }
    }

    /// The key ball is drawn after every other ball, which keep their order; a held ball goes
    /// over all of them, ringed, where the cursor is. Seen to fail with the key ball swapped with
    /// the last ball instead of moved after it: the order became 0, 4, 2, 3.
    #[test]
    fn fill_draws_the_key_ball_last_and_keeps_the_others_in_order() {
        let balls: Vec<Ball> =
            (0..5).map(|i| ball(i, if i == 1 { BallKind::Key } else { BallKind::Ball }, i as f64)).collect();
        let mut s = FrameSnapshot::default();
        s.overlays.push(Segment::default());
        s.fill(Field::default(), &balls);
        assert!(s.overlays.is_empty());
        let order: Vec<f32> = s.balls.iter().map(|b| b.x).collect();
        assert_eq!(order, [0.0, 2.0, 3.0, 4.0, 1.0]);
        assert_eq!(s.balls[4].colour >> 24, BallStyle::Key as u32);
        assert_eq!(s.balls[0], BallSprite::of(&balls[0]));

        s.add_held(&balls[2], DVec2::new(7.0, 8.0));
        let held = s.balls[5];
        assert_eq!((held.x, held.y, held.radius), (7.0, 8.0, 0.5));
        assert_eq!(held.colour, with_style(ball_colour(BallKind::Ball, 2), BallStyle::Held));
    }

    /// The overlays the window draws: the pull (1 m per 100 N from the key ball, none without a
    /// pull), the centre of mass (mass-weighted) and a trace that fades in towards its newest
    /// point. Seen to fail with the centre of mass unweighted (`moment += b.position`).
    #[test]
    fn overlays() {
        let mut s = FrameSnapshot::default();
        s.add_pull(DVec2::new(1.0, 2.0), DVec2::ZERO);
        assert!(s.overlays.is_empty());
        s.add_pull(DVec2::new(1.0, 2.0), DVec2::new(200.0, 0.0));
        assert_eq!(s.overlays[0].ends, [1.0, 2.0, 3.0, 2.0]);

        s.overlays.clear();
        s.add_centre_of_mass(std::iter::empty::<Ball>());
        assert!(s.overlays.is_empty());
        // Masses 1 and 3 at x = 0 and 4: the centre is at x = 3.
        s.add_centre_of_mass([ball(0, BallKind::Ball, 0.0), ball(2, BallKind::Ball, 4.0)]);
        let [x0, y0, x1, y1] = s.overlays[0].ends;
        assert_eq!(((x0 + x1) / 2.0, (y0 + y1) / 2.0), (3.0, 1.0));

        s.overlays.clear();
        let points = [DVec2::ZERO, DVec2::X, DVec2::Y, DVec2::ONE];
        s.add_trace(points, palette::TRACE);
        assert_eq!(s.overlays.len(), 3);
        let alpha: Vec<u32> = s.overlays.iter().map(|o| o.colour >> 24).collect();
        assert!(alpha.windows(2).all(|a| a[0] < a[1]) && alpha[2] <= palette::TRACE >> 24, "{alpha:?}");
        assert_eq!(s.overlays[2].ends, [0.0, 1.0, 1.0, 1.0]);
        s.add_trace([DVec2::ZERO], palette::TRACE);
        assert_eq!(s.overlays.len(), 3);
    }
}
