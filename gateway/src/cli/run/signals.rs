//! SIGINT and SIGTERM, which stop `run` cleanly; SIGHUP, which reads the
//! project again (`reload.rs`).

/// SIGINT and SIGTERM.
pub(crate) struct Signals {
    term: tokio::signal::unix::Signal,
    int: tokio::signal::unix::Signal,
}

impl Signals {
    pub(crate) fn new() -> Result<Signals, miette::Report> {
        use tokio::signal::unix::{signal, SignalKind};
        let err = |e: std::io::Error| miette::miette!("cannot watch for signals: {e}");
        Ok(Signals {
            term: signal(SignalKind::terminate()).map_err(err)?,
            int: signal(SignalKind::interrupt()).map_err(err)?,
        })
    }

    pub(crate) async fn recv(&mut self) {
        tokio::select! {
            _ = self.term.recv() => {}
            _ = self.int.recv() => {}
        }
    }
}

/// Why a wait ended before its work did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Stopped {
    /// SIGINT or SIGTERM.
    Signal,
    /// `--duration` ran out.
    Deadline,
}

impl Signals {
    /// `work`, unless a signal or `deadline` comes first.
    pub(crate) async fn or_stop<T>(
        &mut self,
        work: impl std::future::Future<Output = T>,
        deadline: Option<std::time::Instant>,
    ) -> Result<T, Stopped> {
        let deadline = async {
            match deadline {
                Some(d) => tokio::time::sleep_until(d.into()).await,
                None => std::future::pending().await,
            }
        };
        tokio::select! {
            done = work => Ok(done),
            _ = self.recv() => Err(Stopped::Signal),
            _ = deadline => Err(Stopped::Deadline),
        }
    }
}

impl Stopped {
    /// What `run` or `mirror` (`who`) says when it stopped before its link
    /// at `address` opened, `after` its start.
    pub(crate) fn before_the_link(
        self,
        who: &str,
        address: &str,
        after: std::time::Duration,
    ) -> String {
        match self {
            Stopped::Signal => {
                format!("{who} stopped before the link opened ({address}): nothing recorded")
            }
            Stopped::Deadline => format!(
                "{who} stopped after {:.1} s (--duration) before the link opened ({address}: a `tcpin:` link waits for its client): nothing recorded",
                after.as_secs_f64()
            ),
        }
    }
}

/// SIGHUP: a new version of the project to read (`petrel reload`,
/// systemd's `ExecReload`).
pub(crate) struct Hangup(tokio::signal::unix::Signal);

impl Hangup {
    pub(crate) fn new() -> Result<Hangup, miette::Report> {
        use tokio::signal::unix::{signal, SignalKind};
        signal(SignalKind::hangup())
            .map(Hangup)
            .map_err(|e| miette::miette!("cannot watch for SIGHUP: {e}"))
    }

    pub(crate) async fn recv(&mut self) {
        self.0.recv().await;
    }
}
