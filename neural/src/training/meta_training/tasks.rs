//! The tasks of one outer iteration and which rank adapts which. Every rank draws all the
//! iteration's tasks from the iteration's own seeded generator (cheap: indices and seeds), in
//! the order one process would, and adapts those whose index k has k % world == rank; so the
//! union over the ranks is exactly one process's tasks, whatever the world size.

use super::MetaOptions;
use crate::data::meta_data::MetaData;
use crate::training::collective::Collective;
use rand::seq::index::sample as sample_indices;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

pub(super) fn iteration_rng(seed: u64, stage: u64, iteration: usize) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(
        seed.wrapping_mul(0x2545_F491_4F6C_DD1D) ^ (stage << 40) ^ iteration as u64,
    )
}

/// An Alg. 1 task: one posed frame and the inner fit's seed.
pub(super) struct SdfTask {
    pub sample: usize,
    pub seed: u64,
}

/// An Alg. 2 task: frames of one subject-outfit group and the inner fit's seed.
pub(super) struct HyperTask {
    pub samples: Vec<usize>,
    pub seed: u64,
}

pub(super) fn sdf_tasks(options: &MetaOptions, data: &MetaData, iteration: usize) -> Vec<SdfTask> {
    let mut rng = iteration_rng(options.seed, 1, iteration);
    (0..options.sdf_meta_batch)
        .map(|_| {
            let sample = rng.random_range(0..data.len());
            SdfTask { sample, seed: rng.random() }
        })
        .collect()
}

pub(super) fn hyper_tasks(
    options: &MetaOptions,
    data: &MetaData,
    iteration: usize,
) -> Vec<HyperTask> {
    let mut rng = iteration_rng(options.seed, 2, iteration);
    let groups = &data.manifest.groups;
    (0..options.hyper_meta_batch.max(1))
        .map(|_| {
            let group = &groups[rng.random_range(0..groups.len())];
            let size = rng.random_range(1..=options.hyper_max_task.min(group.samples).max(1));
            let samples = sample_indices(&mut rng, group.samples, size)
                .into_iter()
                .map(|k| group.first_sample + k)
                .collect();
            HyperTask { samples, seed: rng.random() }
        })
        .collect()
}

/// This rank's share of `tasks`, with each task's index.
pub(super) fn mine<'a, T>(
    tasks: &'a [T],
    collective: &'a Collective,
) -> impl Iterator<Item = (usize, &'a T)> + 'a {
    let (rank, world) = (collective.rank(), collective.world());
    tasks.iter().enumerate().filter(move |(k, _)| k % world == rank)
}

/// Add `values / count` to `sum` (the mean over the iteration's tasks, one task at a time in
/// task order on each rank, as one process adds them).
pub(super) fn add_mean(sum: &mut [f32], values: &[f32], count: usize) {
    for (m, v) in sum.iter_mut().zip(values) {
        *m += v / count as f32;
    }
}
