//! A generated world before it is MJCF: rooms, wall lines with their doors, and the items
//! standing in the rooms, all in metres on the floor. The kinds lay out rooms and doors; the
//! furnishing here is shared. Spacing rules keep the world valid by construction: an item
//! either touches a wall or keeps `PASSAGE` from it and from every other item, so no passage is
//! narrower than the robot needs, and door approaches and the spawn stay clear.

use crate::robot::Pose2;
use rand::Rng;
use rand_chacha::ChaCha8Rng;

/// Narrowest gap left between items, and between an item and a wall it does not touch,
/// metres: the robot (0.6 m across) passes with room to turn its corners.
pub const PASSAGE: f64 = 0.85;

/// Depth kept clear on both sides of a door, metres.
const DOOR_APPROACH: f64 = 1.0;

/// Radius kept clear around the spawn, metres.
pub const SPAWN_CLEAR: f64 = 0.9;

/// Room left between a door and a wall junction or a wall's end, metres.
const DOOR_JAMB: f64 = 0.3;

/// An axis-aligned rectangle on the floor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rect {
    /// Lower corner (x, y).
    pub lo: [f64; 2],
    /// Upper corner (x, y).
    pub hi: [f64; 2],
}

impl Rect {
    /// The rectangle from its corners.
    pub fn new(lo: [f64; 2], hi: [f64; 2]) -> Self {
        Rect { lo, hi }
    }

    /// Side along axis `a`.
    pub fn side(&self, a: usize) -> f64 {
        self.hi[a] - self.lo[a]
    }

    /// Area, m2.
    pub fn area(&self) -> f64 {
        self.side(0) * self.side(1)
    }

    /// Shrunk by `d` on every side.
    pub fn shrink(&self, d: f64) -> Rect {
        Rect::new(
            [self.lo[0] + d, self.lo[1] + d],
            [self.hi[0] - d, self.hi[1] - d],
        )
    }

    /// The gap between two rectangles (0 when they touch or overlap), metres.
    pub fn gap(&self, other: &Rect) -> f64 {
        let dx = (other.lo[0] - self.hi[0])
            .max(self.lo[0] - other.hi[0])
            .max(0.0);
        let dy = (other.lo[1] - self.hi[1])
            .max(self.lo[1] - other.hi[1])
            .max(0.0);
        dx.hypot(dy)
    }

    /// Whether the two overlap with positive area.
    pub fn overlaps(&self, other: &Rect) -> bool {
        self.lo[0] < other.hi[0] - 1e-9
            && other.lo[0] < self.hi[0] - 1e-9
            && self.lo[1] < other.hi[1] - 1e-9
            && other.lo[1] < self.hi[1] - 1e-9
    }

    /// Whether (x, y) lies inside.
    pub fn contains(&self, p: [f64; 2]) -> bool {
        (self.lo[0]..=self.hi[0]).contains(&p[0]) && (self.lo[1]..=self.hi[1]).contains(&p[1])
    }
}

/// A straight wall along a centre line: `along` is 0 for a wall running in x (at y = `at`),
/// 1 for one running in y (at x = `at`); it spans `from..to` along its axis, faces included.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WallLine {
    /// The axis the wall runs along.
    pub along: usize,
    /// Its centre line's coordinate on the other axis.
    pub at: f64,
    /// Start along its axis, metres.
    pub from: f64,
    /// End along its axis, metres.
    pub to: f64,
    /// Index into the wall materials.
    pub material: usize,
}

/// An opening in a wall line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Door {
    /// The wall line it is cut into.
    pub wall: usize,
    /// Centre along the wall's axis, metres.
    pub centre: f64,
    /// Clear width, metres.
    pub width: f64,
}

/// A room (or corridor, or open hall) by its free floor.
#[derive(Debug, Clone, PartialEq)]
pub struct Room {
    /// What it is ("room 3", "corridor", "hall").
    pub name: String,
    /// Its floor between the wall faces.
    pub floor: Rect,
    /// Whether furniture goes in.
    pub furnished: bool,
}

/// Something standing on the floor; positions are the centre of its footprint.
#[derive(Debug, Clone, PartialEq)]
pub enum Item {
    /// A box from the floor: cabinets, crates, beds, pallets.
    Block {
        /// Footprint centre.
        centre: [f64; 2],
        /// Half sizes (x, y, z) before the turn.
        half: [f64; 3],
        /// Turn about z, radians.
        yaw: f64,
        /// Material index into the furniture materials.
        material: usize,
    },
    /// A sofa: a seat and a back along its -x side (before the turn).
    Sofa {
        /// Footprint centre.
        centre: [f64; 2],
        /// Half footprint (depth, width) and the seat's half height.
        half: [f64; 3],
        /// Turn about z.
        yaw: f64,
        /// Material.
        material: usize,
    },
    /// An upright cylinder: round tables, bins, barrels, pillars.
    Cylinder {
        /// Centre.
        centre: [f64; 2],
        /// Radius.
        radius: f64,
        /// Half height.
        half_height: f64,
        /// Material.
        material: usize,
    },
    /// A table: a top on four legs (the robot may pass under it).
    Table {
        /// Footprint centre.
        centre: [f64; 2],
        /// Half sizes of the top (x, y).
        half: [f64; 2],
        /// Height of the top's upper face.
        height: f64,
        /// Turn about z.
        yaw: f64,
        /// Material.
        material: usize,
    },
    /// A shelving rack: a plinth, a back panel, boards and goods on them.
    Rack {
        /// Footprint centre.
        centre: [f64; 2],
        /// Half sizes (x, y) and the rack's half height.
        half: [f64; 3],
        /// Boards above the plinth.
        boards: usize,
        /// Goods per board: (offset along x from the centre, half size) each.
        goods: Vec<Vec<(f64, [f64; 3])>>,
        /// Material of the frame.
        material: usize,
    },
    /// The OBJ vase of `worlds/assets/vase.obj`.
    Vase {
        /// Centre of its base.
        centre: [f64; 2],
        /// Turn about z.
        yaw: f64,
    },
    /// A ball on the floor.
    Ball {
        /// Centre (x, y).
        centre: [f64; 2],
        /// Radius.
        radius: f64,
        /// Material.
        material: usize,
    },
}

/// Radius of the vase's base (from `worlds/assets/vase.obj`), metres.
pub const VASE_RADIUS: f64 = 0.26;

impl Item {
    /// The axis-aligned box its footprint fills.
    pub fn bounds(&self) -> Rect {
        let turned = |c: [f64; 2], hx: f64, hy: f64, yaw: f64| {
            let (s, k) = yaw.sin_cos();
            let (ex, ey) = (hx * k.abs() + hy * s.abs(), hx * s.abs() + hy * k.abs());
            Rect::new([c[0] - ex, c[1] - ey], [c[0] + ex, c[1] + ey])
        };
        match self {
            Item::Block {
                centre, half, yaw, ..
            }
            | Item::Sofa {
                centre, half, yaw, ..
            } => turned(*centre, half[0], half[1], *yaw),
            Item::Table {
                centre, half, yaw, ..
            } => turned(*centre, half[0], half[1], *yaw),
            Item::Rack { centre, half, .. } => turned(*centre, half[0], half[1], 0.0),
            Item::Cylinder { centre, radius, .. } | Item::Ball { centre, radius, .. } => {
                turned(*centre, *radius, *radius, 0.0)
            }
            Item::Vase { centre, .. } => turned(*centre, VASE_RADIUS, VASE_RADIUS, 0.0),
        }
    }
}

/// A whole generated world.
#[derive(Debug, Clone)]
pub struct Layout {
    /// The outer walls' centre lines.
    pub outer: Rect,
    /// Wall thickness, metres.
    pub wall_thickness: f64,
    /// Wall height, metres.
    pub wall_height: f64,
    /// Rooms, corridors and halls.
    pub rooms: Vec<Room>,
    /// Wall centre lines, outer walls first.
    pub walls: Vec<WallLine>,
    /// Openings in the walls.
    pub doors: Vec<Door>,
    /// Furniture and clutter.
    pub items: Vec<Item>,
    /// The robot's start.
    pub spawn: Pose2,
}

/// Wall materials (named in the MJCF writer).
pub const WALL_MATERIALS: usize = 4;
/// Furniture materials.
pub const ITEM_MATERIALS: usize = 4;

impl Layout {
    /// A layout with only its outer walls: north and south span the whole width, east and
    /// west fit between them, so no two walls overlap.
    pub fn enclosed(
        outer: Rect,
        wall_thickness: f64,
        wall_height: f64,
        rng: &mut ChaCha8Rng,
    ) -> Self {
        let h = 0.5 * wall_thickness;
        let mut walls = Vec::new();
        for y in [outer.lo[1], outer.hi[1]] {
            walls.push(WallLine {
                along: 0,
                at: y,
                from: outer.lo[0] - h,
                to: outer.hi[0] + h,
                material: rng.gen_range(0..WALL_MATERIALS),
            });
        }
        for x in [outer.lo[0], outer.hi[0]] {
            walls.push(WallLine {
                along: 1,
                at: x,
                from: outer.lo[1] + h,
                to: outer.hi[1] - h,
                material: rng.gen_range(0..WALL_MATERIALS),
            });
        }
        Layout {
            outer,
            wall_thickness,
            wall_height,
            rooms: Vec::new(),
            walls,
            doors: Vec::new(),
            items: Vec::new(),
            spawn: Pose2::default(),
        }
    }

    /// Adds an inner wall on a centre line from one wall face to another; returns its index.
    pub fn add_wall(
        &mut self,
        along: usize,
        at: f64,
        from_line: f64,
        to_line: f64,
        rng: &mut ChaCha8Rng,
    ) -> usize {
        let h = 0.5 * self.wall_thickness;
        self.walls.push(WallLine {
            along,
            at,
            from: from_line + h,
            to: to_line - h,
            material: rng.gen_range(0..WALL_MATERIALS),
        });
        self.walls.len() - 1
    }

    /// The floor inside the outer walls, m2.
    pub fn floor_area(&self) -> f64 {
        self.outer.shrink(0.5 * self.wall_thickness).area()
    }

    /// Where other walls meet wall `w`, as coordinates along it.
    fn junctions(&self, w: usize) -> Vec<f64> {
        let wall = self.walls[w];
        let h = 0.5 * self.wall_thickness;
        self.walls
            .iter()
            .enumerate()
            .filter(|(k, o)| *k != w && o.along != wall.along)
            .filter(|(_, o)| {
                let touches =
                    (o.from - (wall.at + h)).abs() < 1e-6 || (o.to - (wall.at - h)).abs() < 1e-6;
                touches && o.at > wall.from && o.at < wall.to
            })
            .map(|(_, o)| o.at)
            .collect()
    }

    /// Cuts a door of `width` into wall `w` at a random place clear of junctions, other doors
    /// and the wall's ends (within `span` along it when given); false when it does not fit.
    pub fn add_door(
        &mut self,
        w: usize,
        width: f64,
        span: Option<(f64, f64)>,
        rng: &mut ChaCha8Rng,
    ) -> bool {
        let wall = self.walls[w];
        let h = 0.5 * self.wall_thickness;
        let (mut lo, mut hi) = (wall.from, wall.to);
        if let Some((a, b)) = span {
            lo = lo.max(a);
            hi = hi.min(b);
        }
        let mut blocked: Vec<(f64, f64)> = self
            .junctions(w)
            .into_iter()
            .map(|j| (j - h, j + h))
            .collect();
        blocked.extend(
            self.doors
                .iter()
                .filter(|d| d.wall == w)
                .map(|d| (d.centre - 0.5 * d.width, d.centre + 0.5 * d.width)),
        );
        let reach = 0.5 * width + DOOR_JAMB;
        for _ in 0..50 {
            if hi - lo < 2.0 * reach {
                return false;
            }
            let c = rng.gen_range(lo + reach..hi - reach);
            if blocked
                .iter()
                .all(|&(a, b)| c + reach <= a || c - reach >= b)
            {
                self.doors.push(Door {
                    wall: w,
                    centre: c,
                    width,
                });
                return true;
            }
        }
        false
    }

    /// The floor kept clear in front of each door, both sides.
    pub fn door_zones(&self) -> Vec<Rect> {
        self.doors
            .iter()
            .map(|d| {
                let wall = self.walls[d.wall];
                let (a, b) = (
                    d.centre - 0.5 * d.width - 0.3,
                    d.centre + 0.5 * d.width + 0.3,
                );
                let (c, e) = (wall.at - DOOR_APPROACH, wall.at + DOOR_APPROACH);
                if wall.along == 0 {
                    Rect::new([a, c], [b, e])
                } else {
                    Rect::new([c, a], [e, b])
                }
            })
            .collect()
    }

    /// Places the spawn in a random room, `SPAWN_CLEAR` from its walls.
    pub fn place_spawn(&mut self, rng: &mut ChaCha8Rng) {
        let rooms: Vec<Rect> = self
            .rooms
            .iter()
            .map(|r| r.floor.shrink(SPAWN_CLEAR))
            .filter(|r| r.side(0) > 0.0 && r.side(1) > 0.0)
            .collect();
        let room = rooms[rng.gen_range(0..rooms.len())];
        self.spawn = Pose2 {
            x: rng.gen_range(room.lo[0]..=room.hi[0]),
            y: rng.gen_range(room.lo[1]..=room.hi[1]),
            theta: rng.gen_range(-std::f64::consts::PI..std::f64::consts::PI),
        };
    }

    /// Whether `item` may stand here: inside `room` (touching its walls or `PASSAGE` from
    /// them), `PASSAGE` from every other item, off the door approaches and the spawn.
    pub fn fits(&self, item: &Item, room: &Rect, keep_clear: &[Rect]) -> bool {
        let b = item.bounds();
        let inside = b.lo[0] >= room.lo[0] - 1e-9
            && b.lo[1] >= room.lo[1] - 1e-9
            && b.hi[0] <= room.hi[0] + 1e-9
            && b.hi[1] <= room.hi[1] + 1e-9;
        if !inside {
            return false;
        }
        let wall_gaps = [
            b.lo[0] - room.lo[0],
            b.lo[1] - room.lo[1],
            room.hi[0] - b.hi[0],
            room.hi[1] - b.hi[1],
        ];
        if wall_gaps.iter().any(|&g| g > 0.011 && g < PASSAGE) {
            return false;
        }
        let spawn = Rect::new(
            [self.spawn.x - SPAWN_CLEAR, self.spawn.y - SPAWN_CLEAR],
            [self.spawn.x + SPAWN_CLEAR, self.spawn.y + SPAWN_CLEAR],
        );
        if b.overlaps(&spawn)
            || keep_clear
                .iter()
                .chain(self.door_zones().iter())
                .any(|z| b.overlaps(z))
        {
            return false;
        }
        self.items.iter().all(|o| b.gap(&o.bounds()) >= PASSAGE)
    }
}

/// Where a piece goes in a room.
#[derive(Debug, Clone, Copy)]
enum Spot {
    /// Its back against one of the room's walls (0: south, 1: east, 2: north, 3: west).
    Wall(usize),
    /// Out in the room.
    Free,
}

/// A random point for a footprint of half sizes (hx, hy) (hx across the wall) in `room`: its
/// back touching the wall, and either in a corner or `PASSAGE` from the side walls.
fn spot_position(
    room: &Rect,
    spot: Spot,
    hx: f64,
    hy: f64,
    rng: &mut ChaCha8Rng,
) -> Option<([f64; 2], f64)> {
    const TOUCH: f64 = 0.01;
    match spot {
        Spot::Free => {
            let r = hx.max(hy);
            let (x0, x1) = (room.lo[0] + PASSAGE + r, room.hi[0] - PASSAGE - r);
            let (y0, y1) = (room.lo[1] + PASSAGE + r, room.hi[1] - PASSAGE - r);
            (x0 < x1 && y0 < y1).then(|| {
                (
                    [rng.gen_range(x0..x1), rng.gen_range(y0..y1)],
                    rng.gen_range(0.0..std::f64::consts::PI),
                )
            })
        }
        Spot::Wall(side) => {
            // Along the wall: a corner, or anywhere PASSAGE from both ends.
            let along = if side % 2 == 0 { 0 } else { 1 };
            let (a, b) = (room.lo[along] + TOUCH + hy, room.hi[along] - TOUCH - hy);
            if a > b {
                return None;
            }
            let t = match rng.gen_range(0..4) {
                0 => a,
                1 => b,
                _ => {
                    let (c, d) = (a + PASSAGE, b - PASSAGE);
                    if c >= d {
                        return None;
                    }
                    rng.gen_range(c..d)
                }
            };
            // The item's local -x faces the wall; yaw turns it so.
            let (centre, yaw) = match side {
                0 => ([t, room.lo[1] + TOUCH + hx], std::f64::consts::FRAC_PI_2),
                1 => ([room.hi[0] - TOUCH - hx, t], std::f64::consts::PI),
                2 => ([t, room.hi[1] - TOUCH - hx], -std::f64::consts::FRAC_PI_2),
                _ => ([room.lo[0] + TOUCH + hx, t], 0.0),
            };
            Some((centre, yaw))
        }
    }
}

/// What a room is furnished for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Furnishing {
    /// Sofas, beds, tables, cabinets, vases.
    Home,
    /// Desks, cabinets, plants.
    Office,
    /// Crates, pallets, barrels.
    Storage,
}

/// Furnishes `room` with up to `count` pieces that fit the spacing rules and stay off
/// `keep_clear`.
pub fn furnish(
    layout: &mut Layout,
    room: Rect,
    count: usize,
    style: Furnishing,
    keep_clear: &[Rect],
    rng: &mut ChaCha8Rng,
) {
    let mut placed = 0;
    let mut attempts = 0;
    while placed < count && attempts < 40 * count.max(1) {
        attempts += 1;
        if let Some(item) = random_piece(&room, style, rng) {
            if layout.fits(&item, &room, keep_clear) {
                layout.items.push(item);
                placed += 1;
            }
        }
    }
}

fn random_piece(room: &Rect, style: Furnishing, rng: &mut ChaCha8Rng) -> Option<Item> {
    let material = rng.gen_range(0..ITEM_MATERIALS);
    let wall = Spot::Wall(rng.gen_range(0..4));
    let pick = rng.gen_range(0..6);
    let item = match (style, pick) {
        (Furnishing::Home, 0) => {
            let (hx, hy) = (rng.gen_range(0.4..0.5), rng.gen_range(0.8..1.1));
            let (centre, yaw) = spot_position(room, wall, hx, hy, rng)?;
            Item::Sofa {
                centre,
                half: [hx, hy, 0.22],
                yaw,
                material,
            }
        }
        (Furnishing::Home, 1) => {
            let (hx, hy) = (rng.gen_range(0.9..1.05), rng.gen_range(0.7..0.95));
            let (centre, yaw) = spot_position(room, wall, hx, hy, rng)?;
            Item::Block {
                centre,
                half: [hx, hy, 0.25],
                yaw,
                material,
            }
        }
        (Furnishing::Office | Furnishing::Home, 2) => {
            let (hx, hy) = (rng.gen_range(0.35..0.55), rng.gen_range(0.6..0.9));
            let spot = if rng.gen_bool(0.5) { Spot::Free } else { wall };
            let (centre, yaw) = spot_position(room, spot, hx, hy, rng)?;
            Item::Table {
                centre,
                half: [hx, hy],
                height: rng.gen_range(0.72..0.78),
                yaw,
                material,
            }
        }
        (_, 3) => {
            let (hx, hy) = (rng.gen_range(0.2..0.35), rng.gen_range(0.3..0.8));
            let (centre, yaw) = spot_position(room, wall, hx, hy, rng)?;
            Item::Block {
                centre,
                half: [hx, hy, rng.gen_range(0.4..1.0)],
                yaw,
                material,
            }
        }
        (_, 4) => {
            let radius = rng.gen_range(0.18..0.45);
            let spot = if rng.gen_bool(0.5) { Spot::Free } else { wall };
            let (centre, _) = spot_position(room, spot, radius, radius, rng)?;
            Item::Cylinder {
                centre,
                radius,
                half_height: rng.gen_range(0.2..0.5),
                material,
            }
        }
        (Furnishing::Storage, _) => {
            let h = rng.gen_range(0.2..0.45);
            let (hx, hy): (f64, f64) = (rng.gen_range(0.25..0.6), rng.gen_range(0.25..0.6));
            // Out in the room a crate may stand at any angle; against a wall it stands square.
            let (centre, yaw) = if rng.gen_bool(0.5) {
                spot_position(room, Spot::Free, hx.hypot(hy), hx.hypot(hy), rng)?
            } else {
                spot_position(room, wall, hx, hy, rng)?
            };
            Item::Block {
                centre,
                half: [hx, hy, h],
                yaw,
                material,
            }
        }
        (_, 5) if rng.gen_bool(0.3) => {
            let radius = rng.gen_range(0.25..0.35);
            let (centre, _) = spot_position(room, Spot::Free, radius, radius, rng)?;
            Item::Ball {
                centre,
                radius,
                material,
            }
        }
        _ => {
            let (centre, _) = spot_position(room, wall, VASE_RADIUS, VASE_RADIUS, rng)?;
            Item::Vase {
                centre,
                yaw: rng.gen_range(0.0..std::f64::consts::TAU),
            }
        }
    };
    Some(item)
}

/// A cut made by `split_rooms`: the axis the new wall runs along, its coordinate on the other
/// axis, and the room it split.
pub type Cut = (usize, f64, Rect);

/// Splits `rect` into `count` rooms by cutting the largest room across its longer side, each
/// room at least `min_side` on both sides; returns the rooms and the cuts as (axis the cut
/// wall runs along, coordinate, the room it split).
pub fn split_rooms(
    rect: Rect,
    count: usize,
    min_side: f64,
    rng: &mut ChaCha8Rng,
) -> Option<(Vec<Rect>, Vec<Cut>)> {
    let mut rooms = vec![rect];
    let mut cuts = Vec::new();
    while rooms.len() < count {
        let (k, _) = rooms
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.area().total_cmp(&b.1.area()))?;
        let room = rooms[k];
        // The cut runs across the longer side.
        let across = if room.side(0) >= room.side(1) { 0 } else { 1 };
        let length = room.side(across);
        if length < 2.0 * min_side {
            return None;
        }
        let at = room.lo[across] + length * rng.gen_range(0.35..0.65);
        let at = at.clamp(room.lo[across] + min_side, room.hi[across] - min_side);
        let (mut a, mut b) = (room, room);
        a.hi[across] = at;
        b.lo[across] = at;
        rooms[k] = a;
        rooms.push(b);
        cuts.push((1 - across, at, room));
    }
    Some((rooms, cuts))
}
