//! `rome bench data` (and the table every `rome bench` prints): round trips and throughput of the data server,
//! beside a bare Zenoh queryable measured in the same run over the same
//! loopback links, so the figures are a ratio, not a guess about the
//! machine.

use super::peers::{Etcd, EtcdConn, Redis};
use rome_client::net::{open_loopback_peer, NetOptions};
use rome_client::{DataClient, DataOptions};
use serde::Serialize;
use std::time::{Duration, Instant};
use zenoh::Wait;

/// Flags of `rome bench data`.
#[derive(Debug, clap::Args)]
pub struct DataBench {
    /// Client counts to measure, each client on its own Zenoh session.
    #[arg(long, value_delimiter = ',', default_values_t = [1usize, 50])]
    pub clients: Vec<usize>,
    /// Seconds to measure each operation at each client count.
    #[arg(long, default_value_t = 2.0)]
    pub seconds: f64,
    /// Print JSON rows instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Also measure set, signal and wait on a second data server that keeps
    /// its state in DIR (on disk, synced before every answer), beside etcd
    /// when it is installed, in a pass of their own after the other rows.
    #[arg(long, value_name = "DIR")]
    pub data_dir: Option<std::path::PathBuf>,
    /// Run the data server and the bare queryable in this process, beside
    /// the clients, instead of in a process of their own.
    #[arg(long)]
    pub in_process: bool,
    /// Clients reach the data server and the bare queryable over a Unix
    /// socket (Zenoh's unixsock-stream transport) instead of TCP.
    #[arg(long, conflicts_with = "in_process")]
    pub unix: bool,
}

/// Flags of `rome bench serve`.
#[derive(Debug, clap::Args)]
pub struct ServeArgs {
    /// Also listen on this Unix socket.
    #[arg(long, value_name = "PATH")]
    pub unix: Option<std::path::PathBuf>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Op {
    Tcp,
    RedisGet,
    RedisSet,
    Raw,
    RawPayload,
    PubSub,
    Get,
    Set,
    Signal,
    Wait,
    DiskSet,
    DiskSignal,
    DiskWaitSignal,
    EtcdPut,
    EtcdLock,
}

impl Op {
    fn name(self) -> &'static str {
        match self {
            Op::Tcp => "tcp ping-pong",
            Op::RedisGet => "redis GET",
            Op::RedisSet => "redis SET",
            Op::Raw => "zenoh-queryable",
            Op::RawPayload => "zenoh-queryable+body",
            Op::PubSub => "zenoh pub/sub",
            Op::Get => "get",
            Op::Set => "set",
            Op::Signal => "signal",
            Op::Wait => "wait",
            Op::DiskSet => "set, on disk",
            Op::DiskSignal => "signal, on disk",
            Op::DiskWaitSignal => "wait+signal, on disk",
            Op::EtcdPut => "etcd put",
            Op::EtcdLock => "etcd lock+unlock",
        }
    }
}

/// One measured row.
#[derive(Debug, Clone, Serialize)]
pub struct Row {
    /// The operation.
    pub op: &'static str,
    /// Concurrent clients.
    pub clients: usize,
    /// Completed operations per second, all clients together.
    pub ops_per_s: f64,
    /// Median round trip, microseconds.
    pub p50_us: u64,
    /// 99th percentile round trip, microseconds.
    pub p99_us: u64,
    /// Operations measured.
    pub samples: usize,
}

const RAW_KEY: &str = "rome-bench/raw";
/// A client `i` puts on `PING/<i>`; the far end puts the same payload back
/// on `PONG/<i>`: a round trip through pub/sub, with no query machinery.
const PING: &str = "rome-bench/ping";
const PONG: &str = "rome-bench/pong";

/// A semaphore made with more units than any run takes.
const PLENTY: &str = "bench-plenty";

struct Client {
    session: zenoh::Session,
    data: DataClient,
    /// A client of the durable server, when measured.
    disk: Option<(zenoh::Session, DataClient)>,
    /// A connection to the loopback TCP echo.
    tcp: tokio::sync::Mutex<tokio::net::TcpStream>,
    /// A connection to redis-server, when it is installed.
    redis: Option<tokio::sync::Mutex<tokio::net::TcpStream>>,
    /// A connection to etcd, when it is installed and the durable server
    /// is measured.
    etcd: Option<tokio::sync::Mutex<EtcdConn>>,
    /// The durable semaphore of one unit this client takes and gives back,
    /// as it takes its etcd lock.
    lock: String,
    /// The pub/sub round trip: where pings go, where pongs come, and the
    /// last ping's number (a pong of an earlier, abandoned ping is skipped).
    ping: ClientPing,
}

async fn once(client: &Client, op: Op) -> anyhow::Result<()> {
    use tokio::io::{AsyncReadExt, AsyncWriteExt};
    match op {
        Op::Tcp => {
            let mut c = client.tcp.lock().await;
            c.write_all(b"x").await?;
            let mut b = [0u8; 1];
            c.read_exact(&mut b).await?;
        }
        Op::RedisGet | Op::RedisSet => {
            let redis = client
                .redis
                .as_ref()
                .ok_or_else(|| anyhow::anyhow!("no redis-server to measure"))?;
            let mut c = redis.lock().await;
            // The value is always one character, so the reply's length is known.
            let (cmd, want): (&[u8], &[u8]) = if op == Op::RedisGet {
                (b"*2\r\n$3\r\nGET\r\n$5\r\nbench\r\n", b"$1\r\n")
            } else {
                (b"*3\r\n$3\r\nSET\r\n$5\r\nbench\r\n$1\r\n1\r\n", b"+OK\r\n")
            };
            c.write_all(cmd).await?;
            let mut b = vec![0u8; if op == Op::RedisGet { 7 } else { 5 }];
            c.read_exact(&mut b).await?;
            anyhow::ensure!(
                b.starts_with(want),
                "redis answered {:?}",
                String::from_utf8_lossy(&b)
            );
        }
        Op::Raw | Op::RawPayload => {
            let get = if op == Op::RawPayload {
                // What a `set` of the benchmark carries: a JSON body and
                // an op id.
                client
                    .session
                    .get(format!("{RAW_KEY}?op=bench0.1"))
                    .payload(b"1".to_vec())
                    .encoding(zenoh::bytes::Encoding::APPLICATION_JSON)
            } else {
                client.session.get(RAW_KEY)
            };
            let replies = get.await.map_err(|e| anyhow::anyhow!("{e}"))?;
            let reply = replies
                .recv_async()
                .await
                .map_err(|e| anyhow::anyhow!("raw queryable did not answer: {e}"))?;
            anyhow::ensure!(reply.result().is_ok(), "raw queryable answered an error");
        }
        Op::PubSub => {
            let (ping, pong, n) = &client.ping;
            let n = n.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
            ping.put(n.to_le_bytes().to_vec())
                .await
                .map_err(|e| anyhow::anyhow!("{e}"))?;
            loop {
                let sample = pong
                    .recv_async()
                    .await
                    .map_err(|e| anyhow::anyhow!("no pong: {e}"))?;
                if sample.payload().to_bytes().as_ref() == n.to_le_bytes() {
                    break;
                }
            }
        }
        Op::Get => {
            client.data.get("bench/x").await?;
        }
        Op::Set => {
            client.data.set("bench/x", &1).await?;
        }
        Op::Signal => {
            client.data.signal("bench").await?;
        }
        Op::Wait => {
            // A semaphore that never runs out: the wait's own cost.
            client.data.wait(PLENTY).await?;
        }
        Op::DiskSet | Op::DiskSignal | Op::DiskWaitSignal => {
            let (_, data) = client
                .disk
                .as_ref()
                .ok_or_else(|| anyhow::anyhow!("no durable server to measure"))?;
            match op {
                Op::DiskSet => drop(data.set("bench/x", &1).await?),
                Op::DiskSignal => drop(data.signal("bench").await?),
                _ => {
                    data.wait(&client.lock).await?;
                    data.signal(&client.lock).await?;
                }
            }
        }
        Op::EtcdPut | Op::EtcdLock => {
            let etcd = client
                .etcd
                .as_ref()
                .ok_or_else(|| anyhow::anyhow!("no etcd to measure"))?;
            let mut c = etcd.lock().await;
            if op == Op::EtcdPut {
                c.put("bench/x", "1").await?;
            } else {
                c.lock_unlock().await?;
            }
        }
    }
    Ok(())
}

/// Slices each operation's time is cut into, the operations taking turns
/// (here and in `rome bench robot`): a machine whose load drifts during the
/// run weighs on all of them alike, so their ratios hold.
pub(crate) const ROUNDS: u32 = 10;

/// Every client runs `op` one request at a time for `span`: the round
/// trips (µs) and the time they took together.
async fn measure(
    clients: &[Client],
    op: Op,
    span: Duration,
) -> anyhow::Result<(Vec<u64>, Duration)> {
    let deadline = Instant::now() + span;
    let mut tasks = Vec::new();
    for client in clients {
        tasks.push(async move {
            let mut lat = Vec::new();
            while Instant::now() < deadline {
                let t = Instant::now();
                once(client, op).await?;
                lat.push(t.elapsed().as_micros() as u64);
            }
            Ok::<_, anyhow::Error>(lat)
        });
    }
    let started = Instant::now();
    let results = futures_join_all(tasks).await;
    let elapsed = started.elapsed();
    let mut all = Vec::new();
    for r in results {
        all.extend(r?);
    }
    Ok((all, elapsed))
}

/// Each of `ops` warmed up, then measured in [`ROUNDS`] turns of `span /
/// ROUNDS`: one row per operation.
async fn measure_all(
    clients: &[Client],
    ops: &[Op],
    span: Duration,
    mut say: impl FnMut(&str),
) -> anyhow::Result<Vec<Row>> {
    let n = clients.len();
    for &op in ops {
        say(&format!("warming up {}", op.name()));
        measure(clients, op, span / 5).await?;
    }
    let taken = in_turns(ops.len(), span, &mut say, |k, slice| {
        measure(clients, ops[k], slice)
    })
    .await?;
    ops.iter()
        .zip(taken)
        .map(|(op, (lat, elapsed))| Row::from_latencies(op.name(), n, lat, elapsed))
        .collect()
}

/// Operations `0..count` measured in [`ROUNDS`] turns of `span / ROUNDS`
/// each, `slice(k, time)` measuring operation `k` for `time`: for each
/// operation, all its round trips (µs) and the time they took together.
pub(crate) async fn in_turns<Fut>(
    count: usize,
    span: Duration,
    mut say: impl FnMut(&str),
    mut slice: impl FnMut(usize, Duration) -> Fut,
) -> anyhow::Result<Vec<(Vec<u64>, Duration)>>
where
    Fut: std::future::Future<Output = anyhow::Result<(Vec<u64>, Duration)>>,
{
    let mut taken = vec![(Vec::new(), Duration::ZERO); count];
    for round in 0..ROUNDS {
        say(&format!("round {} of {ROUNDS}", round + 1));
        for (k, (lat, spent)) in taken.iter_mut().enumerate() {
            let (more, elapsed) = slice(k, span / ROUNDS).await?;
            lat.extend(more);
            *spent += elapsed;
        }
    }
    Ok(taken)
}

impl Row {
    /// A row from round trips (µs) completed in `elapsed`.
    pub fn from_latencies(
        op: &'static str,
        clients: usize,
        mut lat: Vec<u64>,
        elapsed: Duration,
    ) -> anyhow::Result<Row> {
        anyhow::ensure!(!lat.is_empty(), "no {op} completed");
        lat.sort_unstable();
        let pct = |p: f64| lat[((lat.len() as f64 * p) as usize).min(lat.len() - 1)];
        Ok(Row {
            op,
            clients,
            ops_per_s: lat.len() as f64 / elapsed.as_secs_f64(),
            p50_us: pct(0.50),
            p99_us: pct(0.99),
            samples: lat.len(),
        })
    }
}

/// Drives futures concurrently on this task (no extra dependency).
async fn futures_join_all<F: std::future::Future>(futures: Vec<F>) -> Vec<F::Output> {
    let mut set = Vec::with_capacity(futures.len());
    for f in futures {
        set.push(Box::pin(f));
    }
    let mut out: Vec<Option<F::Output>> = (0..set.len()).map(|_| None).collect();
    std::future::poll_fn(|cx| {
        let mut pending = false;
        for (i, f) in set.iter_mut().enumerate() {
            if out[i].is_none() {
                match f.as_mut().poll(cx) {
                    std::task::Poll::Ready(v) => out[i] = Some(v),
                    std::task::Poll::Pending => pending = true,
                }
            }
        }
        if pending {
            std::task::Poll::Pending
        } else {
            std::task::Poll::Ready(())
        }
    })
    .await;
    out.into_iter().flatten().collect()
}

/// Runs the data benchmark and returns its rows.
pub async fn data_rows(args: &DataBench, progress: bool) -> anyhow::Result<Vec<Row>> {
    anyhow::ensure!(
        args.seconds.is_finite() && args.seconds > 0.0,
        "--seconds must be positive"
    );
    anyhow::ensure!(
        args.clients.iter().all(|&n| (1..=500).contains(&n)),
        "--clients takes counts between 1 and 500"
    );
    let span = Duration::from_secs_f64(args.seconds);
    let socket = args
        .unix
        .then(|| std::env::temp_dir().join(format!("rome-bench-{}.sock", std::process::id())));
    let (far, port) = if args.in_process {
        let (session, port) = open_loopback_peer(&[]).await?;
        (Far::Here(serve_on(session).await?), port)
    } else {
        let (child, port) = Far::start(socket.as_deref())?;
        (child, port)
    };
    let far_end = |port: u16| match &socket {
        Some(path) => NetOptions {
            connect: vec![format!("unixsock-stream/{}", path.display())],
            ..NetOptions::loopback_client(port)
        },
        None => NetOptions::loopback_client(port),
    };
    let tcp_port = echo_server().await?;
    let redis = Redis::start()?;
    let mut ops = vec![
        Op::Tcp,
        Op::Raw,
        Op::RawPayload,
        Op::PubSub,
        Op::Get,
        Op::Set,
        Op::Signal,
        Op::Wait,
    ];
    match &redis {
        Some(_) => {
            ops.insert(1, Op::RedisSet);
            ops.insert(1, Op::RedisGet);
        }
        None => eprintln!("redis-server is not installed: Redis is left out (Debian: apt-get install redis-server)"),
    }
    // etcd beside the durable server only: both sync before answering.
    let etcd = match &args.data_dir {
        Some(_) => Etcd::start()?,
        None => None,
    };
    let mut disk_ops = Vec::new();
    if args.data_dir.is_some() {
        disk_ops.extend([Op::DiskSet, Op::DiskSignal, Op::DiskWaitSignal]);
        match &etcd {
            Some(_) => disk_ops.extend([Op::EtcdPut, Op::EtcdLock]),
            None => eprintln!(
                "etcd is not installed: etcd is left out (Debian: apt-get install etcd-server)"
            ),
        }
    }
    let passes = if disk_ops.is_empty() { 1 } else { 2 };
    let mut rows = Vec::new();
    let mut bar = progress.then(|| {
        rome_common::progress::Progress::bar(
            "bench data",
            "steps",
            (args.clients.len() * (ops.len() + disk_ops.len() + passes * ROUNDS as usize)) as u64,
        )
    });
    let mut step = 0u64;
    for &n in &args.clients {
        if let Some(b) = &mut bar {
            b.step(step, &format!("opening {n} client session(s)"));
        }
        let mut clients = Vec::new();
        for i in 0..n {
            let session = far_end(port).open().await?;
            let data =
                DataClient::connect(&session, DataOptions::new(&format!("bench{i}"))).await?;
            let tcp = tokio::net::TcpStream::connect(("127.0.0.1", tcp_port)).await?;
            tcp.set_nodelay(true)?;
            let redis = match &redis {
                Some(r) => {
                    let c = tokio::net::TcpStream::connect(("127.0.0.1", r.port)).await?;
                    c.set_nodelay(true)?;
                    Some(tokio::sync::Mutex::new(c))
                }
                None => None,
            };
            let ping = pinger(&session, i).await?;
            clients.push(Client {
                etcd: None,
                lock: format!("bench-lock{i}"),
                session,
                data,
                disk: None,
                tcp: tokio::sync::Mutex::new(tcp),
                redis,
                ping,
            });
        }
        clients[0].data.set("bench/x", &0).await?;
        if redis.is_some() {
            once(&clients[0], Op::RedisSet).await?;
        }
        clients[0].data.create_semaphore("bench", 0).await?;
        clients[0]
            .data
            .create_semaphore(PLENTY, u32::MAX as u64)
            .await?;
        let mut say = |what: &str| {
            if let Some(b) = &mut bar {
                b.step(step, &format!("{what} with {n} client(s)"));
            }
            step += 1;
        };
        rows.extend(measure_all(&clients, &ops, span, &mut say).await?);
        if let Some(dir) = &args.data_dir {
            // A pass of its own: the durable server, its Zenoh peer and a
            // session per client exist only while the durable rows are
            // measured, and weigh on no other row.
            say("starting the durable server");
            let durable = Durable::start(dir, &mut clients, etcd.as_ref()).await?;
            rows.extend(measure_all(&clients, &disk_ops, span, &mut say).await?);
            durable.stop(&mut clients).await?;
        }
        for c in clients {
            let _ = c.session.close().await;
        }
    }
    far.stop().await?;
    if let Some(path) = &socket {
        let _ = std::fs::remove_file(path);
    }
    Ok(rows)
}

/// The durable data server in this process, with a session and an etcd
/// connection per client, for the durable pass.
struct Durable {
    session: zenoh::Session,
    server: rome_data::Running,
}

impl Durable {
    async fn start(
        dir: &std::path::Path,
        clients: &mut [Client],
        etcd: Option<&Etcd>,
    ) -> anyhow::Result<Durable> {
        let (session, disk_port) = open_loopback_peer(&[]).await?;
        let config = rome_data::ServerConfig {
            storage: rome_data::Storage::Dir(dir.to_path_buf()),
            ..rome_data::ServerConfig::default()
        };
        let server = rome_data::spawn(session.clone(), config);
        for (i, c) in clients.iter_mut().enumerate() {
            let session = NetOptions::loopback_client(disk_port).open().await?;
            let data =
                DataClient::connect(&session, DataOptions::new(&format!("bench{i}"))).await?;
            data.create_semaphore("bench", 0).await?;
            data.create_semaphore(&c.lock, 1).await?;
            c.disk = Some((session, data));
            if let Some(e) = etcd {
                c.etcd = Some(tokio::sync::Mutex::new(
                    EtcdConn::connect(e.port, &c.lock).await?,
                ));
            }
        }
        Ok(Durable { session, server })
    }

    async fn stop(self, clients: &mut [Client]) -> anyhow::Result<()> {
        for c in clients.iter_mut() {
            c.etcd = None;
            if let Some((session, _)) = c.disk.take() {
                let _ = session.close().await;
            }
        }
        self.server.stop().await?;
        let _ = self.session.close().await;
        Ok(())
    }
}

/// Where the measured servers run.
enum Far {
    /// In this process.
    Here((zenoh::Session, rome_data::Running)),
    /// In a child process (`rome bench serve`), which ends when its stdin
    /// closes: with this process, however that ends.
    Child(std::process::Child),
}

impl Far {
    fn start(unix: Option<&std::path::Path>) -> anyhow::Result<(Far, u16)> {
        use std::io::BufRead;
        let mut command = std::process::Command::new(std::env::current_exe()?);
        command.args(["bench", "serve"]);
        if let Some(path) = unix {
            command.arg("--unix").arg(path);
        }
        let mut child = command
            .stdin(std::process::Stdio::piped())
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::inherit())
            .spawn()
            .map_err(|e| anyhow::anyhow!("cannot start `rome bench serve`: {e}"))?;
        let mut line = String::new();
        if let Some(out) = child.stdout.take() {
            std::io::BufReader::new(out).read_line(&mut line)?;
        }
        match line.trim().parse::<u16>() {
            Ok(port) => Ok((Far::Child(child), port)),
            Err(_) => {
                let _ = child.kill();
                let _ = child.wait();
                anyhow::bail!("`rome bench serve` did not print its port (it printed {line:?})")
            }
        }
    }

    async fn stop(self) -> anyhow::Result<()> {
        match self {
            Far::Here((session, server)) => {
                server.stop().await?;
                let _ = session.close().await;
            }
            Far::Child(mut child) => {
                drop(child.stdin.take());
                let _ = child.wait();
            }
        }
        Ok(())
    }
}

/// Client `i`'s side of the pub/sub round trip, once the far end answers
/// its pings (until then a ping has nobody to reach, or its pong nobody
/// to come back to).
async fn pinger(session: &zenoh::Session, i: usize) -> anyhow::Result<ClientPing> {
    let z = |e: zenoh::Error| anyhow::anyhow!("{e}");
    let pong = session
        .declare_subscriber(format!("{PONG}/{i}"))
        .await
        .map_err(z)?;
    let ping = session
        .declare_publisher(format!("{PING}/{i}"))
        .await
        .map_err(z)?;
    let ready = Instant::now();
    loop {
        ping.put(b"hello".to_vec()).await.map_err(z)?;
        if let Ok(Ok(_)) = tokio::time::timeout(Duration::from_millis(100), pong.recv_async()).await
        {
            break;
        }
        anyhow::ensure!(
            ready.elapsed() < Duration::from_secs(10),
            "the far end's pub/sub echo did not answer within 10 s"
        );
    }
    Ok((ping, pong, std::sync::atomic::AtomicU64::new(0)))
}

type ClientPing = (
    zenoh::pubsub::Publisher<'static>,
    zenoh::pubsub::Subscriber<zenoh::handlers::FifoChannelHandler<zenoh::sample::Sample>>,
    std::sync::atomic::AtomicU64,
);

/// A bare queryable, a pub/sub echo and a data server on `session`.
async fn serve_on(session: zenoh::Session) -> anyhow::Result<(zenoh::Session, rome_data::Running)> {
    session
        .declare_queryable(RAW_KEY)
        .callback(|q| {
            let _ = q.reply(RAW_KEY, b"0".to_vec()).wait();
        })
        .background()
        .await
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let echo = session.clone();
    session
        .declare_subscriber(format!("{PING}/*"))
        .callback(move |s| {
            let Some(i) = s.key_expr().as_str().rsplit('/').next() else {
                return;
            };
            let _ = echo.put(format!("{PONG}/{i}"), s.payload().clone()).wait();
        })
        .background()
        .await
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let server = rome_data::spawn(session.clone(), rome_data::ServerConfig::default());
    Ok((session, server))
}

/// `rome bench serve`: serves until stdin closes.
pub async fn serve(args: ServeArgs) -> anyhow::Result<()> {
    let (session, port) = match &args.unix {
        None => open_loopback_peer(&[]).await?,
        Some(path) => {
            let _ = std::fs::remove_file(path);
            let options = NetOptions {
                listen: vec![
                    "tcp/127.0.0.1:0".into(),
                    format!("unixsock-stream/{}", path.display()),
                ],
                ..NetOptions::loopback(None, &[])
            };
            let session = options.open().await?;
            let port = rome_client::net::bound_port(&session)
                .await
                .ok_or_else(|| anyhow::anyhow!("the far end listens on no loopback port"))?;
            (session, port)
        }
    };
    let (session, server) = serve_on(session).await?;
    println!("{port}");
    tokio::task::spawn_blocking(|| {
        use std::io::Read;
        let mut sink = [0u8; 64];
        let mut stdin = std::io::stdin();
        while stdin.read(&mut sink).is_ok_and(|n| n > 0) {}
    })
    .await?;
    server.stop().await?;
    let _ = session.close().await;
    Ok(())
}

/// A loopback TCP server that sends every byte back: the floor under any
/// request that crosses a TCP link on this host.
async fn echo_server() -> anyhow::Result<u16> {
    use tokio::io::{AsyncReadExt, AsyncWriteExt};
    let listener = tokio::net::TcpListener::bind(("127.0.0.1", 0)).await?;
    let port = listener.local_addr()?.port();
    tokio::spawn(async move {
        while let Ok((mut s, _)) = listener.accept().await {
            let _ = s.set_nodelay(true);
            tokio::spawn(async move {
                let mut b = [0u8; 64];
                while let Ok(n) = s.read(&mut b).await {
                    if n == 0 || s.write_all(&b[..n]).await.is_err() {
                        break;
                    }
                }
            });
        }
    });
    Ok(port)
}

/// The rows as a table, with each p50's ratios to the bare queryable, the
/// TCP floor and Redis GET.
pub fn table(rows: &[Row]) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{:20} {:>7} {:>10} {:>9} {:>9} {:>11} {:>9} {:>11}",
        "operation", "clients", "ops/s", "p50 µs", "p99 µs", "p50 vs raw", "vs tcp", "vs redis"
    );
    let p50 = |op: Op, clients: usize| {
        rows.iter()
            .find(|r| r.op == op.name() && r.clients == clients)
            .map(|r| r.p50_us.max(1) as f64)
    };
    let ratio = |row: &Row, base: Option<f64>| {
        base.map_or("-".to_string(), |b| {
            format!("{:.2}x", row.p50_us as f64 / b)
        })
    };
    for row in rows {
        let _ = writeln!(
            out,
            "{:20} {:>7} {:>10.0} {:>9} {:>9} {:>11} {:>9} {:>11}",
            row.op,
            row.clients,
            row.ops_per_s,
            row.p50_us,
            row.p99_us,
            ratio(row, p50(Op::Raw, row.clients)),
            ratio(row, p50(Op::Tcp, row.clients)),
            ratio(row, p50(Op::RedisGet, row.clients)),
        );
    }
    out
}
