//! Background work. A [`Task`] runs a closure on its own named thread; the closure may send
//! events (progress) and returns one result; each event and the result wake the UI. The studio
//! keeps its tasks by name and polls them in one place (`StudioApp::poll_tasks`).

pub use crate::error::TaskError;
use crossbeam_channel::{Receiver, Sender};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// Called after every event and at the end (the studio asks egui for a repaint).
pub type Wake = Arc<dyn Fn() + Send + Sync>;

/// What a task's closure sees: its event channel and its cancel flag.
pub struct TaskContext<E> {
    events: Sender<E>,
    cancel: Arc<AtomicBool>,
    wake: Wake,
}

impl<E> TaskContext<E> {
    pub fn send(&self, event: E) {
        let _ = self.events.send(event);
        (self.wake)();
    }

    pub fn cancelled(&self) -> bool {
        self.cancel.load(Ordering::Relaxed)
    }

    pub fn cancel_flag(&self) -> &AtomicBool {
        &self.cancel
    }
}

/// A running (or finished, not yet polled) piece of background work. Dropping it asks the
/// work to stop (the flag is the work's to check) and does not wait for the thread.
pub struct Task<T, E = ()> {
    pub name: &'static str,
    /// The events sent so far (disconnected once the work has returned).
    pub events: Receiver<E>,
    result: Receiver<Result<T, TaskError>>,
    cancel: Arc<AtomicBool>,
}

impl<T: Send + 'static, E: Send + 'static> Task<T, E> {
    pub fn spawn(
        name: &'static str,
        wake: Wake,
        work: impl FnOnce(&TaskContext<E>) -> crate::error::Result<T> + Send + 'static,
    ) -> Task<T, E> {
        let (event_tx, events) = crossbeam_channel::unbounded();
        let (result_tx, result) = crossbeam_channel::bounded(1);
        let cancel = Arc::new(AtomicBool::new(false));
        let cx = TaskContext { events: event_tx, cancel: cancel.clone(), wake };
        std::thread::Builder::new()
            .name(name.into())
            .spawn(move || {
                let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| work(&cx)));
                let r = match r {
                    Ok(r) => r.map_err(TaskError::from),
                    Err(_) => Err(TaskError::Panicked(name)),
                };
                let _ = result_tx.send(r);
                let wake = cx.wake.clone();
                drop(cx); // disconnects `events` before the final wake
                wake();
            })
            .unwrap_or_else(|e| panic!("spawning the {name} thread: {e}"));
        Task { name, events, result, cancel }
    }
}

impl<T, E> Task<T, E> {
    /// The result, once the work has returned (then the task is done: drop it).
    pub fn poll(&self) -> Option<Result<T, TaskError>> {
        self.result.try_recv().ok()
    }

    /// The events sent since the last call.
    pub fn drain_events(&self) -> Vec<E> {
        self.events.try_iter().collect()
    }

    pub fn cancel(&self) {
        self.cancel.store(true, Ordering::Relaxed);
    }

    pub fn is_cancelling(&self) -> bool {
        self.cancel.load(Ordering::Relaxed)
    }
}

impl<T, E> Drop for Task<T, E> {
    fn drop(&mut self) {
        self.cancel();
    }
}

/// Poll an optional task slot: the result once it is done (the slot is then emptied).
pub fn take_done<T, E>(slot: &mut Option<Task<T, E>>) -> Option<Result<T, TaskError>> {
    let r = slot.as_ref()?.poll()?;
    *slot = None;
    Some(r)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::StudioError;
    use std::time::{Duration, Instant};

    fn wait<T, E>(t: &Task<T, E>) -> Result<T, TaskError> {
        let start = Instant::now();
        loop {
            if let Some(r) = t.poll() {
                return r;
            }
            assert!(start.elapsed() < Duration::from_secs(10));
            std::thread::sleep(Duration::from_millis(1));
        }
    }

    #[test]
    fn results_events_errors_and_panics() {
        let wakes = Arc::new(std::sync::atomic::AtomicUsize::new(0));
        let w = wakes.clone();
        let wake: Wake = Arc::new(move || {
            w.fetch_add(1, Ordering::SeqCst);
        });
        let t = Task::spawn("adder", wake.clone(), |cx: &TaskContext<u32>| {
            for i in 0..3 {
                cx.send(i);
            }
            Ok(40 + 2)
        });
        assert_eq!(wait(&t).unwrap(), 42);
        assert_eq!(t.drain_events(), vec![0, 1, 2]);
        assert!(wakes.load(Ordering::SeqCst) >= 4, "every event and the end wake the UI");
        let t: Task<()> = Task::spawn("reader", wake.clone(), |_| {
            Err(StudioError::invalid("no such file").context("reading x.json"))
        });
        assert_eq!(wait(&t).unwrap_err().to_string(), "reading x.json: no such file");
        let t: Task<()> = Task::spawn("crasher", wake, |_| panic!("bug"));
        assert!(matches!(wait(&t), Err(TaskError::Panicked("crasher"))));
    }
}
