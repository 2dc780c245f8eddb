//! A rectangle of floor as a grid of square cells, and the flood fill that asks which cells an
//! agent can reach. Furniture placement ([`crate::placement`]) keeps a room's doors joined on
//! one; door leaves ([`crate::doors`]) keep a room passable on another.

use glam::Vec2;

/// Square cells of `cell_m` covering `width` x `height` cells from `origin` (the low corner);
/// cell `k` is column `k % width`, row `k / width`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct FloorGrid {
    pub origin: Vec2,
    pub cell_m: f32,
    pub width: usize,
    pub height: usize,
}

/// What a flood fill reached.
pub(crate) struct Flood {
    /// For every cell, the index of the seed whose fill reached it first (`usize::MAX`: none).
    pub label: Vec<usize>,
    /// How many cells the seeds reached together.
    pub reached: usize,
}

impl FloorGrid {
    /// The cells that fit whole in `size` from `origin`, at least one each way.
    pub fn covering(origin: Vec2, size: Vec2, cell_m: f32) -> FloorGrid {
        let count = |extent: f32| ((extent / cell_m).floor() as usize).max(1);
        FloorGrid { origin, cell_m, width: count(size.x), height: count(size.y) }
    }

    pub fn len(&self) -> usize {
        self.width * self.height
    }

    pub fn centre(&self, k: usize) -> Vec2 {
        self.origin + Vec2::new((k % self.width) as f32 + 0.5, (k / self.width) as f32 + 0.5) * self.cell_m
    }

    /// The cell holding `p`, or the nearest edge cell for a point outside.
    pub fn cell(&self, p: Vec2) -> usize {
        let q = ((p - self.origin) / self.cell_m).floor();
        let x = q.x.clamp(0.0, self.width as f32 - 1.0) as usize;
        let y = q.y.clamp(0.0, self.height as f32 - 1.0) as usize;
        x + y * self.width
    }

    /// Fills from each seed in turn through free cells, stepping to the four side neighbours
    /// (an agent does not squeeze between two diagonal blocked cells). A blocked seed, or one
    /// an earlier seed reached, starts nothing.
    pub fn flood(&self, blocked: &[bool], seeds: &[usize]) -> Flood {
        let mut label = vec![usize::MAX; blocked.len()];
        let mut reached = 0;
        for (i, &start) in seeds.iter().enumerate() {
            if blocked[start] || label[start] != usize::MAX {
                continue;
            }
            label[start] = i;
            let mut stack = vec![start];
            while let Some(k) = stack.pop() {
                reached += 1;
                for n in self.side_neighbours(k).into_iter().flatten() {
                    if label[n] == usize::MAX && !blocked[n] {
                        label[n] = i;
                        stack.push(n);
                    }
                }
            }
        }
        Flood { label, reached }
    }

    fn side_neighbours(&self, k: usize) -> [Option<usize>; 4] {
        let (x, y) = (k % self.width, k / self.width);
        [
            (x > 0).then(|| k - 1),
            (x + 1 < self.width).then(|| k + 1),
            (y > 0).then(|| k - self.width),
            (y + 1 < self.height).then(|| k + self.width),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 5 x 3 grid with a wall down column 2 that leaves a gap in the top row.
    fn walled(gap: bool) -> (FloorGrid, Vec<bool>) {
        let grid = FloorGrid::covering(Vec2::ZERO, Vec2::new(5.0, 3.0), 1.0);
        let mut blocked = vec![false; grid.len()];
        for y in 0..3 {
            blocked[2 + y * 5] = !(gap && y == 2);
        }
        (grid, blocked)
    }

    #[test]
    fn a_wall_splits_the_fill_and_a_gap_joins_it() {
        let (grid, blocked) = walled(false);
        let split = grid.flood(&blocked, &[0, 4]);
        assert_eq!(split.reached, 12);
        assert_eq!(split.label[1], 0);
        assert_eq!(split.label[3], 1);
        let (grid, blocked) = walled(true);
        let joined = grid.flood(&blocked, &[0, 4]);
        assert_eq!(joined.reached, 13);
        assert_eq!(joined.label[4], 0, "the second seed was reached by the first");
    }

    #[test]
    fn diagonal_gaps_do_not_join_and_blocked_seeds_start_nothing() {
        let grid = FloorGrid::covering(Vec2::ZERO, Vec2::new(2.0, 2.0), 1.0);
        let blocked = [false, true, true, false];
        let fill = grid.flood(&blocked, &[0, 1]);
        assert_eq!(fill.reached, 1);
        assert_eq!(fill.label, vec![0, usize::MAX, usize::MAX, usize::MAX]);
    }

    #[test]
    fn points_outside_map_to_the_nearest_edge_cell() {
        let grid = FloorGrid::covering(Vec2::new(1.0, 1.0), Vec2::new(2.5, 2.0), 0.5);
        assert_eq!((grid.width, grid.height), (5, 4));
        assert_eq!(grid.cell(Vec2::new(-3.0, -3.0)), 0);
        assert_eq!(grid.cell(Vec2::new(9.0, 9.0)), grid.len() - 1);
        assert_eq!(grid.cell(grid.centre(7)), 7);
    }
}
