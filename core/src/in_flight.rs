//! A stage's frame files written on a thread while the stage computes the next frame: one frame
//! in flight, and a frame counted done only once its files are written, so that a kill leaves
//! every frame either done and whole or to be done again (each file is written atomically).

use std::thread::{Scope, ScopedJoinHandle};

/// The frame whose files are being written, if any: what the stage reports of it once done
/// (`T`), and the thread writing them.
pub struct OneInFlight<'scope, T, E> {
    writing: Option<(T, ScopedJoinHandle<'scope, Result<(), E>>)>,
}

impl<'scope, T, E: Send + 'scope> OneInFlight<'scope, T, E> {
    /// Waits for the frame in flight, if any, and hands what came with it to `done`. A write's
    /// error is returned; a panic on the writing thread carries on here.
    pub fn wait<F: From<E>>(&mut self, done: impl FnOnce(T) -> Result<(), F>) -> Result<(), F> {
        match self.writing.take() {
            Some((report, handle)) => {
                handle.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic))?;
                done(report)
            }
            None => Ok(()),
        }
    }

    /// Waits for the frame in flight (as [`OneInFlight::wait`]), then starts `write` on a thread
    /// of `scope`, with `report` for its `done`.
    pub fn start<'env, F: From<E>>(
        &mut self,
        scope: &'scope Scope<'scope, 'env>,
        report: T,
        write: impl FnOnce() -> Result<(), E> + Send + 'scope,
        done: impl FnOnce(T) -> Result<(), F>,
    ) -> Result<(), F> {
        self.wait(done)?;
        self.writing = Some((report, scope.spawn(write)));
        Ok(())
    }
}

impl<T, E: Send> Default for OneInFlight<'_, T, E> {
    /// Nothing in flight.
    fn default() -> Self {
        OneInFlight { writing: None }
    }
}

#[cfg(test)]
mod tests {
    use super::OneInFlight;
    use std::sync::Mutex;

    /// Frames are reported done in order, each only after its write has finished, and the last
    /// one at the final wait; a write's error comes back at the next wait.
    #[test]
    fn frames_are_done_in_order_once_written() {
        let written = Mutex::new(Vec::new());
        let was_written = |frame: u32| written.lock().expect("not poisoned").contains(&frame);
        let mut done = Vec::new();
        std::thread::scope(|scope| {
            let mut report = |frame: u32| -> Result<(), String> {
                assert!(was_written(frame), "frame {frame} done before written");
                done.push(frame);
                Ok(())
            };
            let mut writing = OneInFlight::default();
            for frame in 1..=4u32 {
                let written = &written;
                let write = move || -> Result<(), String> {
                    written.lock().expect("not poisoned").push(frame);
                    Ok(())
                };
                writing.start(scope, frame, write, &mut report).expect("written");
            }
            writing.wait(&mut report).expect("written");
            let mut failing = OneInFlight::default();
            failing
                .start(scope, 9, || Err("disk full".to_string()), |_| Ok::<(), String>(()))
                .expect("nothing in flight");
            assert_eq!(failing.wait(|_| Ok::<(), String>(())), Err("disk full".to_string()));
        });
        assert_eq!(done, [1, 2, 3, 4]);
    }
}
