//! The three kinds of generated world, each as rooms, walls and doors on a seeded random
//! draw; furnishing is shared (`layout::furnish`).

use super::layout::{furnish, split_rooms, Furnishing, Item, Layout, Rect, Room, ITEM_MATERIALS};
use rand::Rng;
use rand_chacha::ChaCha8Rng;

/// Wall thickness of every generated world, metres.
const WALL: f64 = 0.12;

/// Narrowest aisle beside a rack in a warehouse, metres.
const AISLE: f64 = 1.5;

/// Smallest room side, metres.
const MIN_ROOM_SIDE: f64 = 2.6;

/// Furnished rooms "room 1", "room 2", ... from their centre-line rectangles.
fn numbered_rooms(rooms: &[Rect]) -> Vec<Room> {
    rooms
        .iter()
        .enumerate()
        .map(|(k, r)| Room {
            name: format!("room {}", k + 1),
            floor: r.shrink(0.5 * WALL),
            furnished: true,
        })
        .collect()
}

fn door_width(rng: &mut ChaCha8Rng) -> f64 {
    rng.gen_range(1.0..=1.4)
}

fn wall_height(rng: &mut ChaCha8Rng) -> f64 {
    rng.gen_range(2.5..=3.0)
}

/// 3-6 rooms cut from one rectangle, each cut with a door (so all rooms connect), sometimes a
/// second door for a loop; furniture in every room.
pub fn apartment(area: f64, rng: &mut ChaCha8Rng) -> Option<Layout> {
    let aspect = rng.gen_range(1.0..1.7);
    let width = (area * aspect).sqrt();
    let outer = Rect::new(
        [-0.5 * width, -0.5 * area / width],
        [0.5 * width, 0.5 * area / width],
    );
    let most = ((area / 12.0).floor() as usize).clamp(3, 6);
    let count = rng.gen_range(3..=most);
    let mut layout = Layout::enclosed(outer, WALL, wall_height(rng), rng);
    let (rooms, cuts) = split_rooms(outer, count, MIN_ROOM_SIDE, rng)?;
    let walls: Vec<usize> = cuts
        .iter()
        .map(|&(along, at, room)| layout.add_wall(along, at, room.lo[along], room.hi[along], rng))
        .collect();
    for w in walls {
        if !layout.add_door(w, door_width(rng), None, rng) {
            return None;
        }
        if layout.walls[w].to - layout.walls[w].from > 6.0 && rng.gen_bool(0.3) {
            layout.add_door(w, door_width(rng), None, rng);
        }
    }
    layout.rooms = numbered_rooms(&rooms);
    layout.place_spawn(rng);
    for room in layout.rooms.clone() {
        let count = ((room.floor.area() / 6.0).round() as usize).clamp(2, 6);
        furnish(&mut layout, room.floor, count, Furnishing::Home, &[], rng);
    }
    Some(layout)
}

/// A corridor along x with 4-8 rooms off one or both sides, each with a door onto it.
pub fn office(area: f64, rng: &mut ChaCha8Rng) -> Option<Layout> {
    let corridor = rng.gen_range(1.6..2.2);
    let both_sides = rng.gen_bool(0.6);
    let depth = [rng.gen_range(3.0..4.5), rng.gen_range(3.0..4.5)];
    let sides = if both_sides { 2 } else { 1 };
    let total_depth: f64 = depth[..sides].iter().sum::<f64>() + corridor;
    let length = area / total_depth;
    let per_side_min = if both_sides { 2 } else { 4 };
    let per_side_max = if both_sides { 4 } else { 8 };
    let widest = (length / MIN_ROOM_SIDE).floor() as usize;
    if widest < per_side_min {
        return None;
    }
    let rooms_per_side = rng.gen_range(per_side_min..=per_side_max.min(widest));
    // y: south rooms from 0 to depth[0], corridor above, north rooms above that.
    let south = depth[0];
    let (corridor_lo, corridor_hi) = (south, south + corridor);
    let top = if both_sides {
        corridor_hi + depth[1]
    } else {
        corridor_hi
    };
    let outer = Rect::new([-0.5 * length, -0.5 * top], [0.5 * length, 0.5 * top]);
    let shift = -0.5 * top;
    let mut layout = Layout::enclosed(outer, WALL, wall_height(rng), rng);
    let mut rooms = Vec::new();
    let mut doors_on = Vec::new();
    let side_bands: Vec<(f64, f64)> = if both_sides {
        vec![
            (shift, shift + corridor_lo),
            (shift + corridor_hi, shift + top),
        ]
    } else {
        vec![(shift, shift + corridor_lo)]
    };
    for &(y0, y1) in &side_bands {
        // The corridor wall of this side, the whole length.
        let at = if (y0 - shift).abs() < 1e-9 { y1 } else { y0 };
        let wall = layout.add_wall(0, at, outer.lo[0], outer.hi[0], rng);
        // Room dividers: cut points along x.
        let mut cuts = vec![outer.lo[0]];
        let unit = length / rooms_per_side as f64;
        for k in 1..rooms_per_side {
            cuts.push(outer.lo[0] + unit * (k as f64 + rng.gen_range(-0.2..0.2)));
        }
        cuts.push(outer.hi[0]);
        for k in 0..rooms_per_side {
            let room = Rect::new([cuts[k], y0], [cuts[k + 1], y1]);
            if k > 0 {
                layout.add_wall(1, cuts[k], y0, y1, rng);
            }
            rooms.push(room);
            doors_on.push((wall, cuts[k], cuts[k + 1]));
        }
    }
    for (wall, a, b) in doors_on {
        if !layout.add_door(wall, door_width(rng), Some((a, b)), rng) {
            return None;
        }
    }
    let corridor_rect = Rect::new(
        [outer.lo[0], shift + corridor_lo],
        [outer.hi[0], shift + corridor_hi],
    );
    layout.rooms = numbered_rooms(&rooms);
    layout.rooms.push(Room {
        name: "corridor".into(),
        floor: corridor_rect.shrink(0.5 * WALL),
        furnished: false,
    });
    // The spawn is anywhere, the corridor included (its ends are the hard case).
    layout.place_spawn(rng);
    for room in layout.rooms.clone().into_iter().filter(|r| r.furnished) {
        let count = ((room.floor.area() / 5.0).round() as usize).clamp(2, 5);
        furnish(&mut layout, room.floor, count, Furnishing::Office, &[], rng);
    }
    Some(layout)
}

/// An open hall with rows of shelving (aisles of 1.6 m or more, cross aisles between rack
/// runs), a strip of 1-3 walled rooms along its west end, and clutter along the walls.
pub fn warehouse(area: f64, rng: &mut ChaCha8Rng) -> Option<Layout> {
    let aspect = rng.gen_range(1.2..1.8);
    let width = (area * aspect).sqrt();
    let height = area / width;
    let outer = Rect::new([-0.5 * width, -0.5 * height], [0.5 * width, 0.5 * height]);
    let mut layout = Layout::enclosed(outer, WALL, wall_height(rng).max(2.8), rng);
    // The walled rooms: a strip along the west wall.
    let strip = rng.gen_range(3.0..4.0);
    let strip_x = outer.lo[0] + strip;
    let room_count = ((height / MIN_ROOM_SIDE).floor() as usize).clamp(1, 3);
    let room_count = rng.gen_range(1..=room_count);
    let strip_wall = layout.add_wall(1, strip_x, outer.lo[1], outer.hi[1], rng);
    let mut cuts = vec![outer.lo[1]];
    for k in 1..room_count {
        cuts.push(outer.lo[1] + height * k as f64 / room_count as f64);
    }
    cuts.push(outer.hi[1]);
    let mut rooms = Vec::new();
    for k in 0..room_count {
        if k > 0 {
            layout.add_wall(0, cuts[k], outer.lo[0], strip_x, rng);
        }
        rooms.push(Rect::new([outer.lo[0], cuts[k]], [strip_x, cuts[k + 1]]));
    }
    for k in 0..room_count {
        if !layout.add_door(
            strip_wall,
            door_width(rng),
            Some((cuts[k], cuts[k + 1])),
            rng,
        ) {
            return None;
        }
    }
    let hall = Rect::new([strip_x, outer.lo[1]], [outer.hi[0], outer.hi[1]]).shrink(0.5 * WALL);
    layout.rooms = numbered_rooms(&rooms);
    layout.rooms.push(Room {
        name: "hall".into(),
        floor: hall,
        furnished: false,
    });
    layout.place_spawn(rng);

    // Shelving: rows along x, separated by aisles; each row cut into runs by cross aisles.
    let perimeter = rng.gen_range(1.8..2.4);
    let aisle = rng.gen_range(1.6..2.4);
    let depth = rng.gen_range(0.8..1.1);
    let racks = Rect::new(
        [hall.lo[0] + perimeter, hall.lo[1] + perimeter],
        [hall.hi[0] - perimeter, hall.hi[1] - perimeter],
    );
    let rows = ((racks.side(1) + aisle) / (depth + aisle)).floor() as usize;
    let spare = racks.side(1) - rows as f64 * depth - rows.saturating_sub(1) as f64 * aisle;
    let zones = layout.door_zones();
    for r in 0..rows {
        let y = racks.lo[1] + 0.5 * spare + r as f64 * (depth + aisle) + 0.5 * depth;
        let mut x = racks.lo[0];
        while x < racks.hi[0] {
            let run = rng.gen_range(3.0..7.0_f64).min(racks.hi[0] - x);
            if run >= 1.5 {
                let rack = rack(
                    x + 0.5 * run,
                    y,
                    0.5 * run,
                    0.5 * depth,
                    layout.wall_height,
                    rng,
                );
                let spawn_clear = rack.bounds().gap(&Rect::new(
                    [layout.spawn.x, layout.spawn.y],
                    [layout.spawn.x, layout.spawn.y],
                )) >= super::layout::SPAWN_CLEAR;
                if spawn_clear && zones.iter().all(|z| !rack.bounds().overlaps(z)) {
                    layout.items.push(rack);
                }
            }
            x += run + rng.gen_range(1.7..2.6);
        }
    }
    // Clutter in the hall keeps every aisle at least AISLE wide.
    let aisles: Vec<Rect> = layout
        .items
        .iter()
        .map(|rack| {
            let b = rack.bounds();
            Rect::new(
                [b.lo[0] - AISLE, b.lo[1] - AISLE],
                [b.hi[0] + AISLE, b.hi[1] + AISLE],
            )
        })
        .collect();
    for room in layout.rooms.clone() {
        let (count, keep_clear) = if room.furnished {
            (
                ((room.floor.area() / 6.0).round() as usize).clamp(2, 4),
                &[][..],
            )
        } else {
            (
                ((room.floor.area() / 25.0).round() as usize).clamp(3, 10),
                &aisles[..],
            )
        };
        furnish(
            &mut layout,
            room.floor,
            count,
            Furnishing::Storage,
            keep_clear,
            rng,
        );
    }
    Some(layout)
}

/// A shelving run of half length `hx` and half depth `hy` at (x, y) with goods on its boards.
fn rack(x: f64, y: f64, hx: f64, hy: f64, wall_height: f64, rng: &mut ChaCha8Rng) -> Item {
    let height = rng.gen_range(1.8..2.2_f64).min(wall_height - 0.3);
    let boards = rng.gen_range(2..=3);
    let goods = (0..=boards)
        .map(|_| {
            let mut on = Vec::new();
            let mut at = -hx + 0.05;
            while at < hx - 0.3 {
                let half = [
                    rng.gen_range(0.12..0.3_f64),
                    rng.gen_range(0.15..hy - 0.02),
                    rng.gen_range(0.1..0.22),
                ];
                if at + 2.0 * half[0] > hx - 0.05 {
                    break;
                }
                if rng.gen_bool(0.7) {
                    on.push((at + half[0], half));
                }
                at += 2.0 * half[0] + rng.gen_range(0.05..0.4);
            }
            on
        })
        .collect();
    Item::Rack {
        centre: [x, y],
        half: [hx, hy, 0.5 * height],
        boards,
        goods,
        material: rng.gen_range(0..ITEM_MATERIALS),
    }
}
