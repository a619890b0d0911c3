//! Paper 004's road: cars in uniform linear motion, a billboard (sec. 2-4).
//!
//! The paper tracks a car in a 320x240 video (dt = 0.04 s, 25 fps) that a
//! billboard hides for some frames. Its Table 2 (PF tracker, every third
//! frame) moves the centre about (2.6, 5) px per frame from (57, 85) to
//! (126, 220); its Table 1 (MAD tracker) stalls at (76, 113) from frame 13,
//! where the billboard is. Table 3 follows two cars (frames 42-53) with
//! windows about 34x46 and 29x43 moving about (4, 2) px per frame.
//!
//! [`RoadScene::default`] is the single-car scene of Tables 1-2 (28 frames):
//! a 24x32 car from (57, 85) at (2.56, 5) px/frame, and a billboard over rows
//! 118-171 that hides it completely in frames 10-14 (0-based) and partly in
//! frames 4-9 and 15-20. [`RoadScene::two_cars`] is the Table 3 scene (12
//! frames standing for the paper's frames 42-53). The images are gray; the
//! road, its markings and the verge texture are static (seeded), so
//! background subtraction sees only the cars.
//!
//! The ground truth is the paper's own trajectory: the single car starts at
//! Table 2's first point and moves at its average pace; the two cars start
//! at Table 3's frame-42 centroids and windows and move at its average pace
//! (without the growth of its windows). A tracker that matches the truth
//! therefore matches those tables by construction; what the scene measures
//! is whether a tracker follows the cars (through the billboard, without a
//! swap), not a reproduction of the paper's numbers.

use bayestrack_image::{Image, Rect};
use rand_xoshiro::Xoshiro256PlusPlus;

use super::render::{ValueNoise, add_noise, blend, clipped_span, pixel_span, rect_cov, to_u8};
use super::{
    FrameTruth, ObjectTruth, Result, SceneError, SceneInfo, SceneStream, check_geometry,
    check_range, name_key, otb_box, scene_rng, streams,
};

const NAME: &str = "road";
const KEY: u64 = name_key(NAME);

/// One car: an axis-aligned textured box in uniform linear motion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Car {
    /// Centre in frame 0 (0-based pixel coordinates).
    pub center: [f64; 2],
    /// Displacement per frame in pixels.
    pub velocity: [f64; 2],
    /// Width and height in pixels.
    pub size: [f64; 2],
    /// Body grey level (the windows, roof, lights and wheels derive from it).
    pub shade: u8,
}

impl Car {
    /// Centre at frame `k`.
    pub fn center_at(&self, k: usize) -> [f64; 2] {
        [
            self.center[0] + k as f64 * self.velocity[0],
            self.center[1] + k as f64 * self.velocity[1],
        ]
    }
}

/// A straight road band.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoadGeometry {
    /// A point on the road's centre line (0-based pixels).
    pub origin: [f64; 2],
    /// Direction of the road (any non-zero length).
    pub direction: [f64; 2],
    /// Width of the road in pixels.
    pub width: f64,
}

/// Parameters of the road scene. `Default` is paper 004's single-car scene
/// (Tables 1-2); see [`RoadScene::two_cars`] for Table 3.
#[derive(Debug, Clone, PartialEq)]
pub struct RoadScene {
    /// Frame width (320).
    pub width: usize,
    /// Frame height (240).
    pub height: usize,
    /// Frames per second (25: the paper's dt = 0.04 s).
    pub fps: f64,
    /// Number of frames.
    pub frames: usize,
    /// The cars, target first; later cars are drawn in front of earlier ones.
    pub cars: Vec<Car>,
    /// The road band.
    pub road: RoadGeometry,
    /// The billboard panel (0-based pixels), drawn in front of the cars;
    /// `None` for no billboard.
    pub billboard: Option<Rect>,
    /// Standard deviation of the sensor noise in grey levels (2).
    pub sensor_noise: f64,
}

impl Default for RoadScene {
    fn default() -> Self {
        Self {
            width: 320,
            height: 240,
            fps: 25.0,
            frames: 28,
            cars: vec![Car {
                center: [57.0, 85.0],
                velocity: [2.56, 5.0],
                size: [24.0, 32.0],
                shade: 55,
            }],
            road: RoadGeometry {
                // The car runs mid-lane, 24 px right of the centre line.
                origin: [78.4, 74.1],
                direction: [2.56, 5.0],
                width: 96.0,
            },
            billboard: Some(Rect::new(50, 118, 90, 54)),
            sensor_noise: 2.0,
        }
    }
}

impl RoadScene {
    /// Paper 004 Table 3: two cars moving along x towards the bottom right,
    /// windows 34x46 and 29x43, no billboard; frame 0 stands for the paper's
    /// frame 42.
    pub fn two_cars() -> Self {
        Self {
            frames: 12,
            cars: vec![
                Car {
                    center: [146.0, 159.0],
                    velocity: [3.9, 2.0],
                    size: [34.0, 46.0],
                    shade: 50,
                },
                Car {
                    center: [186.0, 141.0],
                    velocity: [4.2, 2.0],
                    size: [29.0, 43.0],
                    shade: 190,
                },
            ],
            road: RoadGeometry {
                origin: [166.0, 150.0],
                direction: [4.0, 2.0],
                width: 110.0,
            },
            billboard: None,
            ..Self::default()
        }
    }

    fn validate(&self) -> Result<()> {
        check_geometry(NAME, self.width, self.height, self.fps, self.frames)?;
        let bad = |name, reason: String| SceneError::InvalidParameter {
            scene: NAME,
            name,
            reason,
        };
        if self.cars.is_empty() {
            return Err(bad("cars", "need at least one car".to_string()));
        }
        let big = 4.0 * (self.width + self.height) as f64;
        for c in &self.cars {
            for v in c.center.iter().chain(&c.velocity) {
                check_range(NAME, "car position/velocity", *v, -big, big)?;
            }
            for s in c.size {
                check_range(NAME, "car size", s, 2.0, big)?;
            }
        }
        for v in self.road.origin {
            check_range(NAME, "road origin", v, -big, big)?;
        }
        check_range(NAME, "road width", self.road.width, 0.0, big)?;
        let [dx, dy] = self.road.direction;
        if !(dx.is_finite() && dy.is_finite() && dx.hypot(dy) > 1e-9) {
            return Err(bad("road direction", format!("{:?}", self.road.direction)));
        }
        if let Some(b) = self.billboard
            && !b.fits_in(self.width, self.height)
        {
            return Err(bad(
                "billboard",
                format!("{b} is not inside the {}x{} frame", self.width, self.height),
            ));
        }
        check_range(NAME, "sensor_noise", self.sensor_noise, 0.0, 255.0)
    }

    /// Size, rate and length.
    pub fn info(&self) -> SceneInfo {
        SceneInfo {
            name: NAME,
            width: self.width,
            height: self.height,
            channels: 1,
            fps: self.fps,
            frames: self.frames,
        }
    }

    /// The static background (road, markings, verge) without cars, billboard
    /// or noise: what a background-subtraction tracker would learn.
    ///
    /// # Errors
    /// [`SceneError::InvalidParameter`] for invalid parameters.
    pub fn background(&self, seed: u64) -> Result<Image<u8>> {
        self.validate()?;
        let mut layout = scene_rng(seed, KEY, streams::LAYOUT, 0);
        self.render_background(&mut layout)
    }

    fn render_background(&self, layout: &mut Xoshiro256PlusPlus) -> Result<Image<u8>> {
        let (w, h) = (self.width as f64, self.height as f64);
        let verge = ValueNoise::new(w, h, 9.0, layout);
        let grain = ValueNoise::new(w, h, 3.0, layout);
        let [dx, dy] = self.road.direction;
        let len = dx.hypot(dy);
        let (tx, ty) = (dx / len, dy / len);
        let [ox, oy] = self.road.origin;
        let half = self.road.width / 2.0;
        let img = Image::from_fn(self.width, self.height, |x, y| {
            let (px, py) = (x as f64 - ox, y as f64 - oy);
            let across = -ty * px + tx * py;
            let along = tx * px + ty * py;
            let v = if across.abs() <= half {
                let d = across.abs();
                if d >= half - 4.0 && d <= half - 2.0 {
                    215.0
                } else if d <= 1.0 && along.rem_euclid(24.0) < 12.0 {
                    200.0
                } else {
                    95.0 + 6.0 * grain.at(x as f64, y as f64)
                }
            } else {
                150.0 + 14.0 * verge.at(x as f64, y as f64) + 4.0 * grain.at(x as f64, y as f64)
            };
            to_u8(v)
        })?;
        Ok(img)
    }

    /// A frame-by-frame stream for `seed`.
    ///
    /// # Errors
    /// [`SceneError::InvalidParameter`] for a parameter out of range (no
    /// car, a billboard outside the frame, non-finite numbers, ...).
    pub fn stream(&self, seed: u64) -> Result<RoadStream> {
        self.validate()?;
        let mut layout = scene_rng(seed, KEY, streams::LAYOUT, 0);
        let background = self.render_background(&mut layout)?;
        let n = self.width * self.height;
        let mut front = vec![None; n];
        if let Some(b) = self.billboard {
            let panel = |x: usize, y: usize| {
                let (u, v) = (x - b.x, y - b.y);
                if u < 2 || v < 2 || u + 2 >= b.width || v + 2 >= b.height {
                    70
                } else if (v * 5 / b.height) % 2 == 1 && u > 6 && u + 6 < b.width {
                    55
                } else {
                    228
                }
            };
            for y in b.y..b.bottom() {
                for x in b.x..b.right() {
                    front[y * self.width + x] = Some(panel(x, y));
                }
            }
        }
        Ok(RoadStream {
            params: self.clone(),
            seed,
            next: 0,
            background,
            front,
        })
    }

    /// Renders the whole scene in memory.
    ///
    /// # Errors
    /// As [`RoadScene::stream`].
    pub fn generate(&self, seed: u64) -> Result<super::Scene> {
        Ok(super::Scene::collect(&mut self.stream(seed)?))
    }
}

/// The grey level of a car at relative position `(u, v)` in `[0, 1]^2`
/// (u across, v along the car; the front is at `v = 1`).
fn car_pattern(shade: u8, u: f64, v: f64) -> f64 {
    let s = f64::from(shade);
    let wheel_rows = (0.12..0.30).contains(&v) || (0.70..0.88).contains(&v);
    if (!(0.07..=0.93).contains(&u)) && wheel_rows {
        30.0
    } else if v > 0.93 && !(0.22..=0.78).contains(&u) {
        235.0
    } else if (0.62..0.78).contains(&v) && (0.12..0.88).contains(&u) {
        s * 0.35
    } else if (0.14..0.24).contains(&v) && (0.15..0.85).contains(&u) {
        s * 0.45
    } else if (0.28..0.58).contains(&v) && (0.15..0.85).contains(&u) {
        (s * 1.2 + 10.0).min(250.0)
    } else {
        s
    }
}

/// The road scene frame by frame (see [`RoadScene::stream`]).
#[derive(Debug, Clone)]
pub struct RoadStream {
    params: RoadScene,
    seed: u64,
    next: usize,
    background: Image<u8>,
    /// Billboard pixels (grey level) in front of the cars.
    front: Vec<Option<u8>>,
}

impl RoadStream {
    /// Extent `[x0, x1] x [y0, y1]` of car `i` at frame `k`.
    fn extent(&self, i: usize, k: usize) -> [f64; 4] {
        let c = &self.params.cars[i];
        let [cx, cy] = c.center_at(k);
        let [w, h] = c.size;
        [cx - w / 2.0, cy - h / 2.0, cx + w / 2.0, cy + h / 2.0]
    }

    /// Visible fraction of car `i` at frame `k`: its coverage inside the
    /// frame, not under the billboard nor under a car drawn after it.
    fn visible_fraction(&self, i: usize, k: usize) -> f64 {
        let (w, h) = (self.params.width as i64, self.params.height as i64);
        let [x0, y0, x1, y1] = self.extent(i, k);
        let later: Vec<[f64; 4]> = (i + 1..self.params.cars.len())
            .map(|j| self.extent(j, k))
            .collect();
        let (mut total, mut seen) = (0.0, 0.0);
        for y in pixel_span(y0, y1) {
            for x in pixel_span(x0, x1) {
                let (fx, fy) = (x as f64, y as f64);
                let c = rect_cov(fx, fy, x0, y0, x1, y1);
                total += c;
                if x < 0 || y < 0 || x >= w || y >= h {
                    continue;
                }
                if self.front[(y * w + x) as usize].is_some() {
                    continue;
                }
                let hidden = later
                    .iter()
                    .map(|e| rect_cov(fx, fy, e[0], e[1], e[2], e[3]))
                    .fold(0.0, f64::max);
                seen += c * (1.0 - hidden);
            }
        }
        if total > 0.0 { seen / total } else { 0.0 }
    }

    fn advance(&mut self) -> Option<FrameTruth> {
        if self.next >= self.params.frames {
            return None;
        }
        let k = self.next;
        self.next += 1;
        let objects = (0..self.params.cars.len())
            .map(|i| {
                let [x0, y0, x1, y1] = self.extent(i, k);
                ObjectTruth {
                    id: i,
                    label: "car",
                    bbox: otb_box(x0, y0, x1 - x0, y1 - y0),
                    visible_fraction: self.visible_fraction(i, k),
                }
            })
            .collect();
        Some(FrameTruth {
            index: k,
            time: k as f64 / self.params.fps,
            objects,
            gain: 1.0,
            bounce: false,
            affine: None,
        })
    }

    fn render(&self, k: usize, out: &mut Image<u8>) {
        let p = &self.params;
        out.as_mut_slice()
            .copy_from_slice(self.background.as_slice());
        let stride = out.stride();
        let buf = out.as_mut_slice();
        for i in 0..p.cars.len() {
            let [x0, y0, x1, y1] = self.extent(i, k);
            let shade = p.cars[i].shade;
            for y in clipped_span(y0, y1, p.height) {
                for x in clipped_span(x0, x1, p.width) {
                    let (fx, fy) = (x as f64, y as f64);
                    let c = rect_cov(fx, fy, x0, y0, x1, y1);
                    if c <= 0.0 {
                        continue;
                    }
                    let u = ((fx - x0) / (x1 - x0)).clamp(0.0, 1.0);
                    let v = ((fy - y0) / (y1 - y0)).clamp(0.0, 1.0);
                    let o = y * stride + x;
                    buf[o] = to_u8(blend(f64::from(buf[o]), car_pattern(shade, u, v), c));
                }
            }
        }
        for (o, f) in self.front.iter().enumerate() {
            if let Some(v) = f {
                buf[o] = *v;
            }
        }
        let mut noise = scene_rng(self.seed, KEY, streams::NOISE, k as u64);
        add_noise(buf, p.sensor_noise, &mut noise);
    }
}

impl SceneStream for RoadStream {
    fn info(&self) -> SceneInfo {
        self.params.info()
    }

    fn skip_frame(&mut self) -> Option<FrameTruth> {
        self.advance()
    }

    fn next_into(&mut self, frame: &mut Image<u8>) -> Option<FrameTruth> {
        let truth = self.advance()?;
        if (frame.width(), frame.height(), frame.channels())
            != (self.params.width, self.params.height, 1)
        {
            *frame = self.background.clone();
        }
        self.render(truth.index, frame);
        Some(truth)
    }
}

impl Iterator for RoadStream {
    type Item = super::SceneFrame;
    fn next(&mut self) -> Option<Self::Item> {
        self.next_frame()
    }
}
