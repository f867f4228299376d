//! Builds that speak different protocols find out and say so: the data
//! server refuses a client of another protocol by name, tells a client
//! that says nothing which build it is, and a client of this build names
//! a server that is older or newer than it. Every program says its
//! version beside its liveliness token.

#![allow(clippy::unwrap_used)]

use rome_client::net::{open_loopback_peer, NetOptions};
use rome_client::{ClientError, DataClient, DataOptions};
use rome_schema::version::{Speaks, PROTOCOL};
use rome_schema::{ErrorCode, ErrorReply, Root};
use rome_tests::TestServer;
use std::time::Duration;
use zenoh::Wait;

/// One raw query to `selector` with `attachment`; the error reply's body.
async fn refusal(
    session: &zenoh::Session,
    selector: &str,
    attachment: Option<Vec<u8>>,
) -> ErrorReply {
    let mut get = session.get(selector).timeout(Duration::from_secs(5));
    if let Some(a) = attachment {
        get = get.attachment(a);
    }
    let reply = get.await.unwrap().recv_async().await.unwrap();
    let err = reply.result().expect_err("the server refuses");
    rome_schema::decode(&err.payload().to_bytes(), "error reply").unwrap()
}

fn newer() -> Speaks {
    Speaks {
        version: "9.0.0".into(),
        protocol: PROTOCOL + 1,
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_data_server_refuses_a_client_of_another_protocol_by_name() {
    let server = TestServer::start().await;
    let session = server.session().await;
    let ds = DataClient::connect(&session, DataOptions::new("setup"))
        .await
        .unwrap();
    ds.set("v", &1).await.unwrap();

    // A read that this server understands, from a newer protocol.
    let e = refusal(&session, "rome/data/var/v", Some(newer().to_tag())).await;
    assert_eq!(e.code, ErrorCode::Version, "{e}");
    let this = Speaks::this().to_string();
    assert!(e.message.contains(&this), "names the server's build: {e}");
    assert!(
        e.message.contains("rome 9.0.0 (protocol 2)"),
        "names the client's: {e}"
    );
    assert!(
        e.message.contains("upgrade the data server to rome 9.0.0"),
        "{e}"
    );

    // A client that says nothing, sending what this server does not know:
    // it is told which build the server is.
    let e = refusal(&session, "rome/data/var/v?colour=red", None).await;
    assert_eq!(e.code, ErrorCode::BadParameter, "{e}");
    assert!(e.message.contains("did not say its version"), "{e}");
    assert!(e.message.contains(&this), "{e}");
    // The same mistake from this build is a plain mistake.
    let e = refusal(
        &session,
        "rome/data/var/v?colour=red",
        Some(Speaks::this().to_tag()),
    )
    .await;
    assert_eq!(e.code, ErrorCode::BadParameter, "{e}");
    assert!(!e.message.contains("version"), "{e}");
    // And a request of this build is served.
    assert_eq!(ds.get_as::<i64>("v").await.unwrap(), 1);
    server.stop().await;
}

/// A stand-in data server that refuses everything as `bad_parameter`,
/// saying `speaks` beside its token, or nothing, as a build from before
/// versions does.
async fn refusing_server(speaks: Option<Speaks>) -> (zenoh::Session, u16, Vec<Box<dyn Send>>) {
    let (fake, port) = open_loopback_peer(&[]).await.unwrap();
    let mut held: Vec<Box<dyn Send>> = Vec::new();
    let q = fake
        .declare_queryable("rome/data/**")
        .callback(|q| {
            let e = ErrorReply::new(ErrorCode::BadParameter, "'set' has no parameter 'op'");
            let _ = q.reply_err(rome_schema::encode(&e)).wait();
        })
        .await
        .unwrap();
    held.push(Box::new(q));
    let key = "rome/alive/server/data/fake";
    if let Some(s) = speaks {
        let body = rome_schema::encode(&s);
        let about = fake
            .declare_queryable(key)
            .callback(move |q| {
                let _ = q.reply(key, body.clone()).wait();
            })
            .await
            .unwrap();
        held.push(Box::new(about));
    }
    held.push(Box::new(
        fake.liveliness().declare_token(key).await.unwrap(),
    ));
    (fake, port, held)
}

async fn refused_set(port: u16) -> ClientError {
    let session = NetOptions::loopback(None, &[port]).open().await.unwrap();
    let ds = DataClient::connect(&session, DataOptions::new("versions"))
        .await
        .unwrap();
    ds.set("v", &1).await.expect_err("the stand-in refuses")
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_client_names_a_server_older_or_newer_than_it() {
    // Older than versions: it says nothing.
    let (_fake, port, _held) = refusing_server(None).await;
    let e = refused_set(port).await;
    assert!(matches!(e, ClientError::Versions { .. }), "{e}");
    assert_eq!(e.code(), Some(ErrorCode::BadParameter));
    let m = e.to_string();
    assert!(
        m.contains("has no parameter 'op'"),
        "keeps the refusal: {m}"
    );
    assert!(
        m.contains("the data server is a build older than protocol versions"),
        "{m}"
    );
    assert!(
        m.contains(&format!(
            "upgrade the data server to rome {}",
            Speaks::this().version
        )),
        "{m}"
    );

    // Newer: this client is the one to upgrade.
    let (_fake, port, _held) = refusing_server(Some(newer())).await;
    let m = refused_set(port).await.to_string();
    assert!(
        m.contains("the data server is rome 9.0.0 (protocol 2)"),
        "{m}"
    );
    assert!(
        m.ends_with("upgrade this client to rome 9.0.0 or later"),
        "{m}"
    );

    // The same build: the refusal is the server's, nothing about versions.
    let (_fake, port, _held) = refusing_server(Some(Speaks::this())).await;
    let e = refused_set(port).await;
    assert!(matches!(e, ClientError::Server(_)), "{e}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn every_program_says_its_version_beside_its_token() {
    let server = TestServer::start().await;
    let session = server.session().await;
    let _ds = DataClient::connect(&session, DataOptions::new("lister"))
        .await
        .unwrap();
    let root = Root::default();
    let alive = rome_client::alive::list(&session, &root, Duration::from_secs(1))
        .await
        .unwrap();
    let said = rome_client::alive::versions(&session, &root, Duration::from_secs(1))
        .await
        .unwrap();
    assert_eq!(alive.len(), 2, "{alive:?}");
    for p in &alive {
        let s = said.iter().find(|(k, _)| *k == p.key);
        assert_eq!(
            s.map(|(_, s)| s),
            Some(&Speaks::this()),
            "{} said {said:?}",
            p.key
        );
    }
    server.stop().await;
}

#[test]
fn the_live_list_and_versions_come_back_with_more_programs_than_a_channel_holds() {
    // Forty robots in one process declare some 400 tokens. Their answers
    // come before the query returns its receiver: a channel of 256 filled
    // up and blocked the thread, for ever. So the queries run on a thread
    // of their own, and the test waits for their answer with a deadline.
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let rt = tokio::runtime::Runtime::new().unwrap();
        rt.block_on(async {
            let (session, _port) = open_loopback_peer(&[]).await.unwrap();
            let root = Root::default();
            let mut tokens = Vec::new();
            for k in 0..400 {
                let key = root.alive_client("planner", &format!("many-{k}"));
                tokens.push(rome_serve::presence::declare(&session, &key).await.unwrap());
            }
            let wait = Duration::from_secs(2);
            let listed = rome_client::alive::list(&session, &root, wait)
                .await
                .unwrap();
            let said = rome_client::alive::versions(&session, &root, wait)
                .await
                .unwrap();
            let _ = tx.send((listed.len(), said.len()));
        });
    });
    let got = rx
        .recv_timeout(Duration::from_secs(120))
        .expect("the live list and the versions come back");
    assert_eq!(got, (400, 400));
}
