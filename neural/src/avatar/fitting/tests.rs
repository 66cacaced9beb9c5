use super::*;

/// What a chunk loop asked of a stand-in fit: the runs (first step, steps), the breaks
/// (after step), the partial avatars (after step), and the progress events (step, total).
#[derive(Default)]
struct Calls {
    runs: Vec<(usize, usize)>,
    breaks: Vec<usize>,
    partials: Vec<usize>,
    progress: Vec<(usize, usize)>,
}

fn loop_calls(from: usize, steps: usize, chunk: usize, breaks: &[usize]) -> (usize, Calls) {
    let mut calls = Calls::default();
    let mut last_done = from;
    let mut events = Vec::new();
    let prior = |p: &[Vec3]| vec![0.0; p.len()];
    let mut fit = |c: Chunk| {
        match c {
            Chunk::Run { steps, done, prior, progress } => {
                calls.runs.push((done, steps));
                for i in 0..steps {
                    prior(&[]);
                    progress(i, 0.0, [0.0; 4]);
                }
                last_done = done + steps;
            }
            Chunk::Break => calls.breaks.push(last_done),
            Chunk::Partial(done) => calls.partials.push(done),
        }
        None
    };
    let done = in_chunks(
        from,
        steps,
        chunk,
        breaks,
        None,
        &prior,
        &mut |e| {
            if let FitEvent::Progress { step, steps, .. } = e {
                events.push((step, steps));
            }
        },
        &mut fit,
    );
    calls.progress = events;
    (done, calls)
}

/// The loose cloth's longer fit goes on where the first part stopped: chunks, partial
/// avatars and progress continue from that step, and progress counts to the new total.
#[test]
fn the_chunk_loop_goes_on_from_where_it_stopped_to_a_new_total() {
    let (done, first) = loop_calls(0, 256, 64, &[16, 48]);
    assert_eq!(done, 256);
    assert_eq!(first.runs, [(0, 16), (16, 32), (48, 16), (64, 64), (128, 64), (192, 64)]);
    assert_eq!(first.breaks, [16, 48]);
    assert_eq!(first.partials, [64, 128, 192]);
    assert_eq!(first.progress.first(), Some(&(0, 256)));
    assert_eq!(first.progress.last(), Some(&(255, 256)));

    let (done, more) = loop_calls(256, 512, 64, &[]);
    assert_eq!(done, 512);
    assert_eq!(more.runs, [(256, 64), (320, 64), (384, 64), (448, 64)]);
    assert!(more.breaks.is_empty());
    assert_eq!(more.partials, [320, 384, 448]);
    assert_eq!(more.progress.len(), 256);
    assert_eq!(more.progress.first(), Some(&(256, 512)));
    assert_eq!(more.progress.last(), Some(&(511, 512)));
}

#[test]
fn loose_cloth_gets_the_factor_of_the_steps_and_a_factor_of_one_none() {
    let o = HyperFitOptions::default();
    assert_eq!((o.steps, o.loose_steps()), (256, 512));
    assert_eq!(
        HyperFitOptions { steps: 100, loose_step_factor: 1.5, ..o.clone() }.loose_steps(),
        150
    );
    assert_eq!(HyperFitOptions { loose_step_factor: 1.0, ..o.clone() }.loose_steps(), 256);
    assert_eq!(HyperFitOptions { loose_step_factor: 0.0, ..o }.loose_steps(), 256);
}

/// The plan's count of partial avatars is the chunk loop's, for a fit from its start and for
/// the loose cloth's longer fit that goes on from `steps` (the time left is reckoned from it).
#[test]
fn the_plan_counts_the_partial_avatars_the_loop_makes() {
    for (from, to, chunk) in [(0, 256, 64), (0, 7, 3), (0, 10, 0), (256, 512, 64), (7, 14, 3)] {
        for breaks in [&[][..], &[16, 48]] {
            let (_, calls) = loop_calls(from, to, chunk, breaks);
            assert_eq!(partials(from, to, chunk), calls.partials.len(), "{from}..{to} by {chunk}");
        }
    }
}
