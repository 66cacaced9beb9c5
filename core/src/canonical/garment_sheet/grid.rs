//! A garment sheet's cells: rows up the body, columns round it (the columns wrap round), each
//! cell covered by cloth or not, with the cloth's distance from the axis. The operations are
//! those of a binary image: closing, filling enclosed holes, dropping small islands, and
//! filling unknown values from their neighbours.

/// Cells `rows x columns`, row-major; column `columns - 1` neighbours column 0.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shape {
    pub rows: usize,
    pub columns: usize,
}

impl Shape {
    pub fn len(&self) -> usize {
        self.rows * self.columns
    }

    pub fn index(&self, row: usize, column: usize) -> usize {
        row * self.columns + column % self.columns
    }

    /// The four edge neighbours of a cell (fewer at the first and last rows).
    pub fn neighbours(&self, cell: usize) -> impl Iterator<Item = usize> + use<> {
        let (r, c, shape) = (cell / self.columns, cell % self.columns, *self);
        let left = shape.index(r, c + shape.columns - 1);
        let right = shape.index(r, c + 1);
        let down = (r > 0).then(|| shape.index(r - 1, c));
        let up = (r + 1 < shape.rows).then(|| shape.index(r + 1, c));
        [Some(left), Some(right), down, up].into_iter().flatten()
    }
}

/// `mask` grown by one cell then shrunk by one (4-neighbourhood): notches and one-cell gaps
/// in the cloth close, its outline stays where it was.
pub fn close(shape: Shape, mask: &[bool]) -> Vec<bool> {
    let grown: Vec<bool> =
        (0..shape.len()).map(|i| mask[i] || shape.neighbours(i).any(|n| mask[n])).collect();
    (0..shape.len()).map(|i| grown[i] && shape.neighbours(i).all(|n| grown[n])).collect()
}

/// The 4-connected pieces of the cells where `mask` is `value`: each cell's label
/// (`u32::MAX` elsewhere) and the pieces' sizes.
pub fn pieces(shape: Shape, mask: &[bool], value: bool) -> (Vec<u32>, Vec<usize>) {
    let mut label = vec![u32::MAX; shape.len()];
    let mut sizes = Vec::new();
    let mut stack = Vec::new();
    for start in 0..shape.len() {
        if mask[start] != value || label[start] != u32::MAX {
            continue;
        }
        let id = sizes.len() as u32;
        let mut size = 0;
        label[start] = id;
        stack.push(start);
        while let Some(cell) = stack.pop() {
            size += 1;
            for n in shape.neighbours(cell) {
                if mask[n] == value && label[n] == u32::MAX {
                    label[n] = id;
                    stack.push(n);
                }
            }
        }
        sizes.push(size);
    }
    (label, sizes)
}

/// `mask` with every hole filled: a piece of uncovered cells that touches neither the first
/// nor the last row is enclosed by cloth on every side (a tear through a skirt's front), while
/// the open space round a garment (above a skirt's waist, below its hem, in front of a cape)
/// reaches the first or the last row.
pub fn fill_enclosed(shape: Shape, mask: &[bool]) -> Vec<bool> {
    let (label, sizes) = pieces(shape, mask, false);
    let mut open = vec![false; sizes.len()];
    for c in 0..shape.columns {
        for r in [0, shape.rows - 1] {
            let l = label[shape.index(r, c)];
            if l != u32::MAX {
                open[l as usize] = true;
            }
        }
    }
    (0..shape.len()).map(|i| mask[i] || !open[label[i] as usize]).collect()
}

/// `mask` with each column's gaps of at most `rows` cells between cloth above and cloth below
/// filled (hanging cloth hangs from its top: a short gap in a column is a tear), and each
/// row's gaps of at most `columns` cells between cloth either side (the columns wrap).
pub fn fill_short_gaps(shape: Shape, mask: &[bool], rows: usize, columns: usize) -> Vec<bool> {
    let mut out = mask.to_vec();
    for c in 0..shape.columns {
        let mut last: Option<usize> = None;
        for r in 0..shape.rows {
            if mask[shape.index(r, c)] {
                if let Some(l) = last
                    && r - l - 1 <= rows
                {
                    for k in l + 1..r {
                        out[shape.index(k, c)] = true;
                    }
                }
                last = Some(r);
            }
        }
    }
    let vertical = out.clone();
    for r in 0..shape.rows {
        let cloth: Vec<usize> =
            (0..shape.columns).filter(|&c| vertical[shape.index(r, c)]).collect();
        if cloth.len() < 2 {
            continue;
        }
        for (k, &c) in cloth.iter().enumerate() {
            let next = cloth[(k + 1) % cloth.len()];
            let gap = (next + shape.columns - c - 1) % shape.columns;
            if gap > 0 && gap <= columns {
                for g in 1..=gap {
                    out[shape.index(r, c + g)] = true;
                }
            }
        }
    }
    out
}

/// Each cell of `mask` without a value in `known` takes the mean of its neighbours' (a
/// discrete Laplace equation: the values fill a hole as a membrane spans a frame), by
/// Gauss-Seidel sweeps from the neighbours' mean. Cells left without any known value in reach
/// stay `None`.
pub fn fill_values(
    shape: Shape,
    mask: &[bool],
    known: &[Option<f32>],
    sweeps: usize,
) -> Vec<Option<f32>> {
    let mut value: Vec<Option<f32>> =
        (0..shape.len()).map(|i| if mask[i] { known[i] } else { None }).collect();
    let unknown: Vec<usize> = (0..shape.len()).filter(|&i| mask[i] && known[i].is_none()).collect();
    // Seed: repeatedly give unknown cells the mean of their set neighbours, so sweeps start
    // near the answer (a wide hole fills from its rim inward).
    let mut pending = unknown.clone();
    while !pending.is_empty() {
        let seeded: Vec<(usize, f32)> = pending
            .iter()
            .filter_map(|&i| {
                let (sum, n) = shape
                    .neighbours(i)
                    .filter(|&n| mask[n])
                    .filter_map(|n| value[n])
                    .fold((0.0, 0), |(s, k), v| (s + v, k + 1));
                (n > 0).then(|| (i, sum / n as f32))
            })
            .collect();
        if seeded.is_empty() {
            break;
        }
        for &(i, v) in &seeded {
            value[i] = Some(v);
        }
        pending.retain(|&i| value[i].is_none());
    }
    for _ in 0..sweeps {
        for &i in &unknown {
            let (sum, n) = shape
                .neighbours(i)
                .filter(|&n| mask[n])
                .filter_map(|n| value[n])
                .fold((0.0, 0), |(s, k), v| (s + v, k + 1));
            if n > 0 {
                value[i] = Some(sum / n as f32);
            }
        }
    }
    value
}

/// `value` on the cells of `mask` smoothed by `sweeps` Jacobi sweeps: each cell moves half
/// way toward the mean of its neighbours along the grid's axes (round the body, up it) where
/// it has cloth on both sides along that axis. Lumps a few cells across (the fitted SDF's
/// specks, the depth's noise) flatten, while a radius that changes linearly along a row or a
/// column (a cone, the slope of a flare) stays exactly, at the borders too: a waist or a hem
/// cell has no second neighbour up or down, so it is smoothed only along the row.
pub fn smooth_values(shape: Shape, mask: &[bool], value: &mut [Option<f32>], sweeps: usize) {
    let columns = shape.columns;
    let cloth = |value: &[Option<f32>], r: usize, c: usize| {
        let i = shape.index(r, c);
        if mask[i] { value[i] } else { None }
    };
    for _ in 0..sweeps {
        let next: Vec<Option<f32>> = (0..shape.len())
            .map(|i| {
                let v = value[i]?;
                if !mask[i] {
                    return Some(v);
                }
                let (r, c) = (i / columns, i % columns);
                let round = (cloth(value, r, c + columns - 1), cloth(value, r, c + 1));
                let up = (
                    r.checked_sub(1).and_then(|d| cloth(value, d, c)),
                    (r + 1 < shape.rows).then(|| cloth(value, r + 1, c)).flatten(),
                );
                let (sum, axes) = [round, up]
                    .into_iter()
                    .filter_map(|pair| match pair {
                        (Some(a), Some(b)) => Some(0.5 * (a + b)),
                        _ => None,
                    })
                    .fold((0.0, 0), |(sum, axes), m| (sum + m, axes + 1));
                if axes == 0 {
                    return Some(v);
                }
                let mean = sum / axes as f32;
                Some(v + 0.5 * (mean - v))
            })
            .collect();
        value.copy_from_slice(&next);
    }
}

/// The median of the known values among a cell's eight neighbours (the columns wrapping).
pub fn neighbour_median(shape: Shape, known: &[Option<f32>], cell: usize) -> Option<f32> {
    let (r, c) = ((cell / shape.columns) as isize, cell % shape.columns);
    let mut values: Vec<f32> = Vec::with_capacity(8);
    for dr in -1isize..=1 {
        for dc in [shape.columns - 1, 0, 1] {
            let rr = r + dr;
            if (dr == 0 && dc == 0) || rr < 0 || rr >= shape.rows as isize {
                continue;
            }
            if let Some(v) = known[shape.index(rr as usize, c + dc)] {
                values.push(v);
            }
        }
    }
    if values.is_empty() {
        return None;
    }
    values.sort_by(f32::total_cmp);
    Some(values[values.len() / 2])
}

/// The lowest cloth cell of each column (`None` where the column has none).
fn bottoms(shape: Shape, mask: &[bool], radius: &[Option<f32>]) -> Vec<Option<usize>> {
    (0..shape.columns)
        .map(|c| {
            (0..shape.rows)
                .find(|&r| mask[shape.index(r, c)] && radius[shape.index(r, c)].is_some())
        })
        .collect()
}

/// The hem as a running median of the columns' lowest cells over `2 * half + 1` columns: a
/// column hanging lower than its neighbours' median (a tongue where the rays grazed the rim)
/// loses the cells below it, one ending higher (a notch) gains cells down to it, their
/// radius the mean of the same row's cloth in the window (else the column's lowest). A hem
/// wider than the window keeps its shape. Windows with fewer than `half + 1` columns of cloth
/// (a cape's side edge) are left as they are.
pub fn even_hem(shape: Shape, mask: &mut [bool], radius: &mut [Option<f32>], half: usize) {
    let bottom = bottoms(shape, mask, radius);
    let window =
        |c: usize| (0..=2 * half).map(move |k| (c + shape.columns * 2 + k - half) % shape.columns);
    let targets: Vec<Option<usize>> = (0..shape.columns)
        .map(|c| {
            bottom[c]?;
            let mut rows: Vec<usize> = window(c).filter_map(|n| bottom[n]).collect();
            if rows.len() < half + 1 {
                return None;
            }
            rows.sort_unstable();
            Some(rows[rows.len() / 2])
        })
        .collect();
    for c in 0..shape.columns {
        let (Some(b), Some(t)) = (bottom[c], targets[c]) else { continue };
        if b < t {
            for r in b..t {
                let cell = shape.index(r, c);
                mask[cell] = false;
                radius[cell] = None;
            }
        } else {
            let fallback = radius[shape.index(b, c)];
            for r in t..b {
                let row: Vec<f32> = window(c)
                    .filter(|&n| n != c && mask[shape.index(r, n)])
                    .filter_map(|n| radius[shape.index(r, n)])
                    .collect();
                let cell = shape.index(r, c);
                mask[cell] = true;
                radius[cell] = if row.is_empty() {
                    fallback
                } else {
                    Some(row.iter().sum::<f32>() / row.len() as f32)
                };
            }
        }
    }
}
