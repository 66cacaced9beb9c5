//! `fit`'s progress line (the phase under way, the step, the loss, the time left from the
//! fit's plan: `avatar_neural::avatar::TimeLeft`) and its `--timings` table.

use avatar_neural::avatar::{FitEvent, FitPhase, TimeLeft};
use avatar_studio::studio::measure::cpu_seconds;
use std::io::Write;
use std::time::Instant;

pub struct FitProgress {
    start: Instant,
    left: TimeLeft,
    phase: Option<FitPhase>,
    /// The last progress event: step (from 1), steps, loss, terms.
    step: Option<(usize, usize, f32, [f32; 4])>,
    /// Phases outside the fit proper (canonicalization, saving): label, seconds, CPU seconds.
    outer: Vec<(&'static str, f64, f64)>,
    /// CPU seconds of the process per phase of the fit, and where the current one started.
    cpu: [f64; 5],
    cpu_at: Option<(FitPhase, f64)>,
}

impl FitProgress {
    pub fn new() -> FitProgress {
        FitProgress {
            start: Instant::now(),
            left: TimeLeft::default(),
            phase: None,
            step: None,
            outer: Vec::new(),
            cpu: [0.0; 5],
            cpu_at: None,
        }
    }

    fn now(&self) -> f64 {
        self.start.elapsed().as_secs_f64()
    }

    /// Time `work` as a phase of its own (before or after the fit).
    pub fn outer<T>(&mut self, label: &'static str, work: impl FnOnce() -> T) -> T {
        let (t, cpu) = (Instant::now(), cpu_seconds());
        let out = work();
        self.outer.push((label, t.elapsed().as_secs_f64(), cpu_seconds() - cpu));
        out
    }

    /// The fit's events; the line is redrawn on each.
    pub fn event(&mut self, event: &FitEvent) {
        let at = self.now();
        match event {
            FitEvent::Plan(plan) => self.left.plan(*plan),
            FitEvent::Phase(phase) => {
                self.close_cpu();
                self.cpu_at = Some((*phase, cpu_seconds()));
                self.left.phase(*phase, at);
                self.phase = Some(*phase);
            }
            FitEvent::Progress { step, steps, loss, terms } => {
                self.left.steps(step + 1, at);
                self.step = Some((step + 1, *steps, *loss, *terms));
            }
            FitEvent::Partial { .. } => {}
        }
        self.draw(at);
    }

    fn draw(&self, at: f64) {
        let (done, steps) = self.step.map_or((0, 0), |s| (s.0, s.1));
        let fraction = if steps > 0 { done as f64 / steps as f64 } else { 0.0 };
        let bar: String =
            (0..20).map(|i| if (i as f64) < fraction * 20.0 { '#' } else { '.' }).collect();
        let phase = self.phase.map_or("starting", FitPhase::label);
        let loss = match self.step {
            Some((_, _, loss, t)) => format!(
                " loss {loss:>9.3} (surface {:.3} normal {:.3} off {:.3} eikonal {:.3})",
                t[0], t[1], t[2], t[3]
            ),
            None => String::new(),
        };
        let left = match self.left.left(at) {
            Some(s) => format!("{s:>4.0} s left"),
            None => "estimating".into(),
        };
        eprint!("\r\x1b[2Kfit [{bar}] {phase:<24} step {done:>5}/{steps}{loss} {left} ");
        let _ = std::io::stderr().flush();
    }

    /// The fit returned.
    pub fn finish(&mut self) {
        self.close_cpu();
        let at = self.now();
        self.left.finish(at);
    }

    fn close_cpu(&mut self) {
        if let Some((phase, start)) = self.cpu_at.take() {
            let i = FitPhase::ALL.iter().position(|p| *p == phase).expect("every phase listed");
            self.cpu[i] += cpu_seconds() - start;
        }
    }

    /// The phase table (`--timings`): wall and CPU seconds, share and count per phase.
    pub fn table(&self) -> String {
        let mut rows: Vec<(String, f64, f64, String)> = Vec::new();
        let mut outer = self.outer.iter();
        if let Some((label, s, cpu)) = outer.next() {
            rows.push((label.to_string(), *s, *cpu, String::new()));
        }
        for ((phase, seconds, count), cpu) in self.left.spent().zip(self.cpu) {
            if seconds > 0.0 {
                let each = seconds / count.max(1) as f64;
                let count = match phase {
                    FitPhase::Training => format!("{count} steps, {:.1} ms each", each * 1e3),
                    _ => format!("{count} x {each:.2} s"),
                };
                rows.push((phase.label().to_string(), seconds, cpu, count));
            }
        }
        rows.extend(outer.map(|(label, s, cpu)| (label.to_string(), *s, *cpu, String::new())));
        let total: f64 = rows.iter().map(|r| r.1).sum();
        let total_cpu: f64 = rows.iter().map(|r| r.2).sum();
        let mut out =
            String::from("| phase | wall (s) | share | CPU (s) | count |\n|---|---|---|---|---|\n");
        for (label, s, cpu, count) in rows {
            let share = 100.0 * s / total.max(1e-9);
            out += &format!("| {label} | {s:.2} | {share:.0} % | {cpu:.1} | {count} |\n");
        }
        out += &format!("| total | {total:.2} | | {total_cpu:.1} | |\n");
        out
    }
}
