//! A TCP relay standing for a wireless link, under the control of a test
//! or of `rome soak`: every byte is held back `delay` in each direction;
//! the link can be *paused* (bytes stop flowing and wait; the sockets stay
//! open, as when a radio link goes quiet) and resumed, when the held bytes
//! go on in order; and it can be *cut*: every connection through it is
//! closed at once, as when a link drops, and new ones are let through.

use std::net::SocketAddr;
use std::time::Duration;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::sync::{mpsc, watch};
use tokio::time::Instant;

/// A running relay; it stops when dropped.
pub struct Relay {
    /// Where it listens.
    pub addr: SocketAddr,
    paused: watch::Sender<bool>,
    cuts: watch::Sender<u64>,
    task: tokio::task::JoinHandle<()>,
}

impl Relay {
    /// Listens on `listen` (port 0: any) and relays every connection to
    /// `upstream`, each direction `delay` late.
    pub async fn start(
        listen: SocketAddr,
        upstream: SocketAddr,
        delay: Duration,
    ) -> std::io::Result<Relay> {
        let listener = tokio::net::TcpListener::bind(listen).await?;
        let addr = listener.local_addr()?;
        let (paused, watch) = watch::channel(false);
        let (cuts, cut_watch) = watch::channel(0u64);
        let task = tokio::spawn(async move {
            while let Ok((inbound, _)) = listener.accept().await {
                let Ok(outbound) = tokio::net::TcpStream::connect(upstream).await else {
                    continue;
                };
                let _ = inbound.set_nodelay(true);
                let _ = outbound.set_nodelay(true);
                let (ri, wi) = inbound.into_split();
                let (ro, wo) = outbound.into_split();
                let a = tokio::spawn(pipe(ri, wo, delay, watch.clone()));
                let b = tokio::spawn(pipe(ro, wi, delay, watch.clone()));
                // Both directions end when the link is cut.
                let mut cut = cut_watch.clone();
                cut.mark_unchanged();
                tokio::spawn(async move {
                    if cut.changed().await.is_ok() {
                        a.abort();
                        b.abort();
                    }
                });
            }
        });
        Ok(Relay {
            addr,
            paused,
            cuts,
            task,
        })
    }

    /// Closes every connection through the relay now; later connections
    /// go through as before.
    pub fn cut(&self) {
        self.cuts.send_modify(|n| *n += 1);
    }

    /// Stops the bytes (they wait in the relay).
    pub fn pause(&self) {
        let _ = self.paused.send(true);
    }

    /// Lets the held bytes and the new ones through again.
    pub fn resume(&self) {
        let _ = self.paused.send(false);
    }
}

impl Drop for Relay {
    fn drop(&mut self) {
        self.task.abort();
    }
}

/// One direction: a reader that stamps each chunk with when it may go,
/// and a writer that sends it then (and not while paused).
async fn pipe(
    mut from: tokio::net::tcp::OwnedReadHalf,
    mut to: tokio::net::tcp::OwnedWriteHalf,
    delay: Duration,
    mut paused: watch::Receiver<bool>,
) {
    let (tx, mut rx) = mpsc::unbounded_channel::<(Instant, Vec<u8>)>();
    let reader = AbortOnDrop(tokio::spawn(async move {
        let mut buf = vec![0u8; 65536];
        loop {
            match from.read(&mut buf).await {
                Ok(0) | Err(_) => break,
                Ok(n) => {
                    if tx
                        .send((Instant::now() + delay, buf[..n].to_vec()))
                        .is_err()
                    {
                        break;
                    }
                }
            }
        }
    }));
    while let Some((due, bytes)) = rx.recv().await {
        tokio::time::sleep_until(due).await;
        while *paused.borrow() {
            if paused.changed().await.is_err() {
                return;
            }
        }
        if to.write_all(&bytes).await.is_err() {
            break;
        }
    }
    let _ = to.shutdown().await;
    drop(reader);
}

/// Ends a task when dropped: a cut link aborts a pipe, and its reader
/// must end with it.
struct AbortOnDrop(tokio::task::JoinHandle<()>);

impl Drop for AbortOnDrop {
    fn drop(&mut self) {
        self.0.abort();
    }
}
