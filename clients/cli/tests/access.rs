//! Access control, against the deploy/ configuration: `rome certs` makes
//! the credentials, `rome router -c deploy/secure/router.json5` checks
//! them (mutual TLS, user name and password) and applies the roles; a data
//! server (`data`) and a simulated world (`sim`) serve through it. Then:
//! sessions without credentials, with a stranger's certificate or a wrong
//! password are refused; an observer reads but its `move`, `set` and plain
//! put do nothing; an operator's do; a robot cannot answer for another or
//! forge its lock record, while it can for itself.

#![allow(clippy::unwrap_used)]

use rome_client::net::{NetOptions, Secrets};
use rome_client::{DataClient, DataOptions, RobotClient, RobotOptions};
use rome_tests::ChildGuard;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};
use zenoh::Session;

fn exe() -> String {
    rome_tests::rome_exe(env!("CARGO_BIN_EXE_rome"))
}

fn router_config() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../deploy/secure/router.json5")
        .display()
        .to_string()
}

fn rome(args: &[&str], log: &Path) -> ChildGuard {
    rome_tests::spawn_logged(&exe(), args, log)
}

fn net(port: u16, secrets: Option<Secrets>) -> NetOptions {
    NetOptions {
        mode: Some("client".into()),
        connect: vec![format!("tls/127.0.0.1:{port}")],
        no_multicast: true,
        secrets,
        ..NetOptions::default()
    }
}

fn as_(dir: &Path, identity: &str) -> Option<Secrets> {
    Some(Secrets {
        dir: dir.to_path_buf(),
        identity: identity.into(),
    })
}

async fn open(port: u16, dir: &Path, identity: &str) -> Session {
    net(port, as_(dir, identity)).open().await.unwrap()
}

/// A data client that gives up quickly: a denied request goes unanswered.
async fn data(session: &Session, role: &str) -> DataClient {
    let o = DataOptions {
        request_timeout: Duration::from_secs(2),
        connect_timeout: Duration::from_secs(60),
        ..DataOptions::new(role)
    };
    DataClient::connect(session, o).await.unwrap()
}

/// Every reply to `selector`, as text (errors prefixed `error:`).
/// Every reply to a query, as text. A query is finished as soon as every
/// queryable it reaches has answered (or none matches): the timeout only
/// bounds a slow answer. With 2 s, one query of a loaded CI run came back
/// with no reply at all where r1 answers every time.
async fn replies(session: &Session, selector: &str) -> Vec<String> {
    let got = session
        .get(selector)
        .timeout(Duration::from_secs(10))
        .await
        .unwrap();
    let mut out = Vec::new();
    while let Ok(reply) = got.recv_async().await {
        out.push(match reply.result() {
            Ok(s) => String::from_utf8_lossy(&s.payload().to_bytes()).into_owned(),
            Err(e) => format!("error:{}", String::from_utf8_lossy(&e.payload().to_bytes())),
        });
    }
    out
}

struct Deployment {
    dir: PathBuf,
    port: u16,
    _router: ChildGuard,
    _data: ChildGuard,
    _sim: ChildGuard,
    /// Last, so the processes are gone before their files.
    _root: rome_tests::TestDir,
}

async fn deploy() -> Deployment {
    let root = rome_tests::TestDir::new("rome-access");
    let dir = root.path().to_path_buf();
    let secrets = dir.join("secrets");
    let secrets_s = secrets.display().to_string();
    let log = dir.join("rome.log");
    let made = Command::new(exe())
        .args(["certs", &secrets_s])
        .output()
        .unwrap();
    assert!(made.status.success(), "rome certs: {made:?}");
    let config = router_config();
    let (router, port, _) = rome_tests::spawn_listening(
        &exe(),
        &[
            "-c",
            &config,
            "--identity",
            "router",
            "--secrets",
            &secrets_s,
            "-l",
            "tls/127.0.0.1:0",
            "router",
            "--in-memory",
        ],
    );
    let ep = format!("tls/127.0.0.1:{port}");
    let via = |who: &'static str| {
        [
            "--no-multicast",
            "-m",
            "client",
            "-e",
            ep.as_str(),
            "--identity",
            who,
            "--secrets",
            secrets_s.as_str(),
        ]
        .map(String::from)
        .to_vec()
    };
    let args = |mut v: Vec<String>, more: &[&str]| {
        v.extend(more.iter().map(|s| s.to_string()));
        v
    };
    let data_args = args(via("data"), &["data-server", "--in-memory"]);
    let sim_args = args(
        via("sim"),
        &["sim", "--robots", "2", "--at", "350R,376L", "--no-storage"],
    );
    let data = rome(&strs(&data_args), &log);
    let sim = rome(&strs(&sim_args), &log);
    Deployment {
        dir: secrets,
        port,
        _router: router,
        _data: data,
        _sim: sim,
        _root: root,
    }
}

fn strs(v: &[String]) -> Vec<&str> {
    v.iter().map(String::as_str).collect()
}

async fn await_robot(session: &Session, robot: &str) {
    rome_client::alive::await_server(
        session,
        &rome_schema::Root::default(),
        "robot",
        &format!("{robot}/base"),
        Duration::from_secs(60),
    )
    .await
    .unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn sessions_without_the_right_credentials_are_refused() {
    let d = deploy().await;
    // The right ones get in (so the refusals below are about credentials).
    open(d.port, &d.dir, "observer")
        .await
        .close()
        .await
        .unwrap();

    // No credentials at all: no certificate to show, no password.
    let e = net(d.port, None).open().await.unwrap_err().to_string();
    assert!(e.contains("--identity"), "{e}");
    // Nothing listens in the clear.
    let mut tcp = net(d.port, None);
    tcp.connect = vec![format!("tcp/127.0.0.1:{}", d.port)];
    assert!(tcp.open().await.is_err(), "a plain TCP session got in");

    // A certificate from another authority, with the right password.
    let stranger = d.dir.parent().unwrap().join("stranger");
    let made = Command::new(exe())
        .args(["certs", stranger.to_str().unwrap(), "--names", "observer"])
        .output()
        .unwrap();
    assert!(made.status.success());
    std::fs::copy(
        d.dir.join("observer.password"),
        stranger.join("observer.password"),
    )
    .unwrap();
    std::fs::remove_file(stranger.join("users.txt")).unwrap();
    let e = net(d.port, as_(&stranger, "observer"))
        .open()
        .await
        .unwrap_err()
        .to_string();
    assert!(e.contains("identity 'observer'"), "{e}");

    // The deployment's certificate with a wrong password.
    let wrong = d.dir.parent().unwrap().join("wrong");
    std::fs::create_dir_all(&wrong).unwrap();
    for f in ["ca.pem", "observer.pem", "observer-key.pem"] {
        std::fs::copy(d.dir.join(f), wrong.join(f)).unwrap();
    }
    std::fs::write(wrong.join("observer.password"), "not-the-password\n").unwrap();
    assert!(
        net(d.port, as_(&wrong, "observer")).open().await.is_err(),
        "a wrong password got in"
    );
    // Another user's password with the observer's certificate.
    std::fs::copy(
        d.dir.join("operator.password"),
        wrong.join("observer.password"),
    )
    .unwrap();
    assert!(
        net(d.port, as_(&wrong, "observer")).open().await.is_err(),
        "the operator's password opened the observer's session"
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_observer_reads_but_cannot_move_or_write_and_an_operator_can() {
    let d = deploy().await;
    let operator = open(d.port, &d.dir, "operator").await;
    let observer = open(d.port, &d.dir, "observer").await;
    await_robot(&operator, "r1").await;
    let op_data = data(&operator, "operator").await;
    let ob_data = data(&observer, "observer").await;

    // Reads work for the observer.
    op_data.set("Goal", &"376L").await.unwrap();
    assert_eq!(
        ob_data.get("Goal").await.unwrap(),
        serde_json::json!("376L")
    );
    let ob_robot = RobotClient::connect(&observer, "r1", RobotOptions::new("observer"))
        .await
        .unwrap();
    let before = ob_robot.pose().await.unwrap();
    // Anyone may ask each program's version, through the access control.
    let said = rome_client::alive::versions(
        &observer,
        &rome_schema::Root::default(),
        Duration::from_secs(2),
    )
    .await
    .unwrap();
    let keys: Vec<&str> = said.iter().map(|(k, _)| k.as_str()).collect();
    assert!(
        keys.contains(&"rome/alive/server/robot/r1/base"),
        "{keys:?}"
    );
    assert!(
        keys.iter()
            .any(|k| k.starts_with("rome/alive/server/data/")),
        "{keys:?}"
    );
    assert!(
        keys.iter()
            .any(|k| k.starts_with("rome/alive/client/operator/")),
        "{keys:?}"
    );

    // Writes do not: the acknowledged one is never answered …
    assert!(ob_data.set("Goal", &"HACKED").await.is_err());
    // … and a plain put never arrives (an operator's put after it does).
    observer
        .put("rome/data/var/Goal", "\"PUT-BY-OBSERVER\"")
        .await
        .unwrap();
    observer.put("rome/data/var/Probe", "1").await.unwrap();
    operator.put("rome/data/var/Probe", "2").await.unwrap();
    rome_tests::eventually(Duration::from_secs(10), "the operator's put lands", || {
        let d = op_data.clone();
        async move {
            d.get("Probe")
                .await
                .is_ok_and(|v| v == serde_json::json!(2))
        }
    })
    .await;
    assert_eq!(op_data.history("Probe").await.unwrap().stored, 1);
    assert_eq!(
        op_data.get("Goal").await.unwrap(),
        serde_json::json!("376L")
    );
    assert!(ob_data.create_semaphore("s", 1).await.is_err());

    // The observer's move is refused and the robot does not move.
    assert!(ob_robot.move_by(2000.0, -1.0, -1.0).await.is_err());
    assert!(ob_robot.go(300.0).await.is_err());
    let op_robot = RobotClient::connect(&operator, "r1", RobotOptions::new("operator"))
        .await
        .unwrap();
    let mode = op_robot.mode().await.unwrap();
    assert_eq!(
        mode.mode.as_str(),
        "joystick",
        "the observer moved the base"
    );
    let after = ob_robot.pose().await.unwrap();
    assert_eq!((before.x_mm, before.y_mm), (after.x_mm, after.y_mm));

    // The operator's move is carried out.
    op_robot.move_by(300.0, -1.0, -1.0).await.unwrap();
    let deadline = Instant::now() + Duration::from_secs(30);
    loop {
        let p = op_robot.pose().await.unwrap();
        if (p.x_mm - before.x_mm).abs() + (p.y_mm - before.y_mm).abs() > 100 {
            break;
        }
        assert!(Instant::now() < deadline, "the operator's move did nothing");
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_robot_cannot_answer_for_another_or_forge_its_lock_record() {
    let d = deploy().await;
    let operator = open(d.port, &d.dir, "operator").await;
    let r1 = open(d.port, &d.dir, "r1").await;
    await_robot(&operator, "r2").await;
    let fake = "{\"x_mm\":123456789,\"y_mm\":0,\"heading_deg\":0.0}";

    // r1 may serve its own keys …
    let _own = r1
        .declare_queryable("rome/robot/r1/extra/**")
        .callback(move |q| {
            let key = q.key_expr().clone();
            let _ = zenoh::Wait::wait(q.reply(key, fake));
        })
        .await
        .unwrap();
    rome_tests::eventually(Duration::from_secs(10), "r1 answers for itself", || {
        let s = operator.clone();
        async move { replies(&s, "rome/robot/r1/extra/pose").await == vec![fake.to_string()] }
    })
    .await;
    // … but not r2's: whatever it declares there, only r2's server answers.
    let _theirs = r1
        .declare_queryable("rome/robot/r2/base/**")
        .callback(move |q| {
            let key = q.key_expr().clone();
            let _ = zenoh::Wait::wait(q.reply(key, fake));
        })
        .await
        .unwrap();
    let _extra = r1
        .declare_queryable("rome/robot/r2/extra/**")
        .callback(move |q| {
            let key = q.key_expr().clone();
            let _ = zenoh::Wait::wait(q.reply(key, fake));
        })
        .await
        .unwrap();
    // Declarations travel in order with r1's answers for itself: once one
    // of those is seen again, the ones above have reached the router.
    rome_tests::eventually(
        Duration::from_secs(10),
        "r1 answers for itself again",
        || {
            let s = operator.clone();
            async move { replies(&s, "rome/robot/r1/extra/pose").await == vec![fake.to_string()] }
        },
    )
    .await;
    for _ in 0..5 {
        let got = replies(&operator, "rome/robot/r2/base/pose").await;
        assert!(
            got.len() == 1 && got[0].contains("x_mm") && !got[0].contains("123456789"),
            "r2's pose: {got:?}"
        );
        assert!(replies(&operator, "rome/robot/r2/extra/pose")
            .await
            .is_empty());
    }

    // r2's lock record: the sim's is there; r1's forgery never lands, while
    // r1's own record, put after it, does.
    let r2_lock = "rome/store/robot/r2/base/lock";
    let op_robot = RobotClient::connect(&operator, "r2", RobotOptions::new("operator"))
        .await
        .unwrap();
    let lock = op_robot.lock().await.unwrap();
    let fence = lock.fence();
    rome_tests::eventually(Duration::from_secs(10), "r2's record is stored", || {
        let s = operator.clone();
        async move {
            replies(&s, r2_lock)
                .await
                .iter()
                .any(|r| r.contains(&fence.to_string()))
        }
    })
    .await;
    let forged = format!(
        "{{\"holder\":{{\"holder\":\"{}-forged\",\"fence\":{}}},\"last_fence\":{},\"ttl_ms\":600000}}",
        r1.zid(),
        fence + 1000,
        fence + 1000
    );
    r1.put(r2_lock, forged.clone()).await.unwrap();
    r1.put("rome/store/robot/r1/probe", "\"after\"")
        .await
        .unwrap();
    rome_tests::eventually(Duration::from_secs(10), "r1's own record lands", || {
        let s = operator.clone();
        async move { replies(&s, "rome/store/robot/r1/probe").await == vec!["\"after\"".to_string()] }
    })
    .await;
    let stored = replies(&operator, r2_lock).await;
    assert!(
        stored.len() == 1 && !stored[0].contains("forged"),
        "r2's record: {stored:?}"
    );
    // And r1 cannot read it either, to learn r2's fence.
    assert!(replies(&r1, r2_lock).await.is_empty());
    lock.unlock().await.unwrap();
}
