//! Progress of long loops: an [`indicatif`] bar when stderr is a terminal, otherwise (a pipe,
//! a file, CI) a plain line about every tenth of the loop, so logs get no `\r` or escape codes.

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::sync::LazyLock;

/// Every bar of the process, so that nested loops (a reference traced inside a run's frame
/// loop) stack their bars instead of drawing over each other.
static BARS: LazyLock<MultiProgress> = LazyLock::new(MultiProgress::new);

/// True when bars are drawn: indicatif's own rule (stderr is a terminal).
fn on_terminal() -> bool {
    !ProgressDrawTarget::stderr().is_hidden()
}

/// One loop's progress; its bar is cleared when it is dropped.
pub struct Progress {
    bar: Option<ProgressBar>,
    label: String,
    total: u64,
    /// Steps between plain lines.
    every: u64,
    /// Step at which the next plain line is printed.
    next: u64,
}

impl Progress {
    /// A loop of `total` steps called `label`; without a terminal it prints about `lines`
    /// lines over the loop (the last at `total`).
    pub fn new(label: impl Into<String>, total: u64, lines: u64) -> Self {
        let label = label.into();
        let bar = on_terminal().then(|| {
            let bar = BARS.add(ProgressBar::new(total));
            bar.set_style(
                ProgressStyle::with_template("{prefix} [{bar:30}] {pos}/{len} {msg}")
                    .expect("the template is valid")
                    .progress_chars("=> "),
            );
            bar.set_prefix(label.clone());
            bar
        });
        let every = total.div_ceil(lines.max(1)).max(1);
        Progress {
            bar,
            label,
            total,
            every,
            next: every.min(total),
        }
    }

    /// `done` steps are done; `msg` says how it goes (only built when shown).
    pub fn set(&mut self, done: u64, msg: impl FnOnce() -> String) {
        if let Some(bar) = &self.bar {
            bar.set_position(done);
            bar.set_message(msg());
        } else if done >= self.next {
            let msg = msg();
            let sep = if msg.is_empty() { "" } else { ": " };
            eprintln!("{} {done}/{}{sep}{msg}", self.label, self.total);
            self.next = if done >= self.total {
                u64::MAX
            } else {
                ((done / self.every + 1) * self.every).min(self.total)
            };
        }
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        if let Some(bar) = self.bar.take() {
            bar.finish_and_clear();
            BARS.remove(&bar);
        }
    }
}

/// Prints a line on stderr above any bars (which would otherwise draw over it).
pub fn println(line: &str) {
    if on_terminal() {
        // A failed write to the terminal leaves nothing better to do with the line.
        let _ = BARS.println(line);
    } else {
        eprintln!("{line}");
    }
}
