//! Starting hardware servers as tasks: one task per device, so one
//! failing does not stop the others (§4.7: servers stay independent).
//! A simulated robot's set of servers is started by `rome-sim-hardware`.

use crate::camera;
use crate::server::{self, ServerConfig, ServerError, Service};
use std::time::Duration;
use zenoh::Session;

/// Rates of a robot's servers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rates {
    /// How often the base publishes its state (`None`: never).
    pub state: Option<Duration>,
    /// How often the proximity server looks for a new scan to publish.
    pub scan: Option<Duration>,
    /// How often each camera grabs.
    pub camera: Duration,
}

impl Default for Rates {
    fn default() -> Self {
        Rates {
            state: Some(Duration::from_millis(100)),
            scan: Some(Duration::from_millis(50)),
            camera: camera::DEFAULT_PERIOD,
        }
    }
}

/// A hardware server running in a task of this process.
pub struct Running {
    label: String,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    task: tokio::task::JoinHandle<Result<(), ServerError>>,
}

impl Running {
    /// A server's task, told to stop through `stop`.
    pub fn new(
        label: &str,
        stop: tokio::sync::oneshot::Sender<()>,
        task: tokio::task::JoinHandle<Result<(), ServerError>>,
    ) -> Running {
        Running {
            label: label.to_string(),
            stop: Some(stop),
            task,
        }
    }

    /// `robot r1 base` …
    pub fn label(&self) -> &str {
        &self.label
    }

    /// Whether the task has ended (stopped, failed or aborted).
    pub fn is_finished(&self) -> bool {
        self.task.is_finished()
    }

    /// Kills the server at once, as a crash would.
    pub fn abort(&self) {
        self.task.abort();
    }

    /// Stops the server and waits for it; `Ok` if it had already ended.
    pub async fn stop(mut self) -> Result<(), ServerError> {
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(());
        }
        match self.task.await {
            Ok(result) => result,
            Err(_) => Ok(()),
        }
    }
}

/// Runs `service` as a hardware server in a task.
pub fn spawn<S: Service>(session: &Session, config: ServerConfig, service: S) -> Running {
    let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
    let label = config.label();
    // A participant of the run's clock when started in one (lock-step).
    let task = rome_clock::spawn(
        &label,
        server::run(session.clone(), config, service, async move {
            let _ = stopped.await;
        }),
    );
    Running::new(&label, stop, task)
}
