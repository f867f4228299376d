//! Tests of `foxglove`.

use super::*;

use futures_util::{SinkExt, StreamExt};
use tokio_tungstenite::tungstenite::client::IntoClientRequest;
use tokio_tungstenite::tungstenite::Message as Ws;
use zenoh::Wait;

type Client =
    tokio_tungstenite::WebSocketStream<tokio_tungstenite::MaybeTlsStream<tokio::net::TcpStream>>;

/// The next frame, text parsed; the limit is a failure detector.
async fn next(client: &mut Client) -> Ws {
    tokio::time::timeout(std::time::Duration::from_secs(20), client.next())
        .await
        .expect("nothing came from the bridge")
        .expect("the bridge closed the connection")
        .expect("a broken frame")
}

async fn next_text(client: &mut Client) -> Value {
    match next(client).await {
        Ws::Text(t) => serde_json::from_str(t.as_str()).expect("JSON"),
        other => panic!("not text: {other:?}"),
    }
}

/// A bridge served on a free loopback port.
struct Running {
    stop: tokio::sync::oneshot::Sender<()>,
    server: tokio::task::JoinHandle<anyhow::Result<()>>,
}

impl Running {
    async fn stop(self, client: Client) {
        let _ = self.stop.send(());
        drop(client);
        self.server.await.unwrap().unwrap();
    }
}

/// Serves `bridge` on a free loopback port; its URL.
async fn start(bridge: Bridge) -> (String, Running) {
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let at = listener.local_addr().unwrap();
    let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
    let server = tokio::spawn(serve(listener, bridge, async {
        let _ = stopped.await;
    }));
    (format!("ws://{at}/"), Running { stop, server })
}

/// Serves `bridge` and connects to it as Foxglove does.
async fn connect(bridge: Bridge) -> (Client, Running) {
    let (url, running) = start(bridge).await;
    (greeted(&url).await, running)
}

/// A connection to `url` as Foxglove makes it, through the handshake
/// and the server's greeting.
async fn greeted(url: &str) -> Client {
    let mut request = url.into_client_request().unwrap();
    request
        .headers_mut()
        .insert("Sec-WebSocket-Protocol", SUBPROTOCOL.parse().unwrap());
    let (mut client, response) = tokio_tungstenite::connect_async(request).await.unwrap();
    assert_eq!(
        response.headers()["sec-websocket-protocol"],
        SUBPROTOCOL,
        "the subprotocol Foxglove asks for is agreed"
    );
    let info = next_text(&mut client).await;
    assert_eq!(info["op"], "serverInfo", "{info}");
    client
}

/// Sends `request`, then one the bridge refuses: requests are taken in
/// order, so once the refusal is back the first is in place.
async fn request(client: &mut Client, request: String) {
    client.send(Ws::text(request)).await.unwrap();
    client
        .send(Ws::text(r#"{"op":"unsubscribe","subscriptionIds":[404]}"#))
        .await
        .unwrap();
    let s = next_text(client).await;
    assert_eq!(s["message"], "no subscription 404", "{s}");
}

/// Foxglove's side of the protocol against a bridge on an isolated
/// session: the handshake, channels known before and made after the
/// client came, a subscription's messages byte for byte, and bad
/// requests answered with what was wrong while the connection goes on.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn foxglove_sees_every_json_key_as_a_channel_and_gets_what_it_subscribes_to() {
    let session = rome_common::isolated_session().await;
    let put = |key: &'static str, text: &'static str| {
        session.put(key, text).encoding(Encoding::APPLICATION_JSON)
    };
    put("t/r1/state", r#"{"x":1.5,"moving":false}"#)
        .await
        .unwrap();
    let bridge = Bridge::start(&session, &["t/**".to_string()])
        .await
        .unwrap();
    // Heard before any client: a put on the same session reaches the
    // subscriber before `put` returns.
    put("t/r1/state", r#"{"x":2.5,"moving":true}"#)
        .await
        .unwrap();
    let (mut client, running) = connect(bridge).await;
    let ad = next_text(&mut client).await;
    assert_eq!(ad["op"], "advertise", "{ad}");
    let state = &ad["channels"][0];
    assert_eq!(state["topic"], "t/r1/state");
    assert_eq!(state["encoding"], "json");
    assert_eq!(state["schemaName"], "rome.BaseState");
    let schema: Value = serde_json::from_str(state["schema"].as_str().unwrap()).unwrap();
    assert_eq!(schema["properties"]["x"]["type"], "number", "{schema}");
    let state_id = state["id"].as_u64().unwrap();

    // Bad requests, each answered, and the connection goes on.
    client.send(Ws::text("not json")).await.unwrap();
    let s = next_text(&mut client).await;
    assert_eq!(
        (s["op"].as_str(), s["level"].as_u64()),
        (Some("status"), Some(2))
    );
    assert!(
        s["message"]
            .as_str()
            .unwrap()
            .contains("cannot take this request"),
        "{s}"
    );
    client
        .send(Ws::text(
            r#"{"op":"subscribe","subscriptions":[{"id":1,"channelId":99}]}"#,
        ))
        .await
        .unwrap();
    let s = next_text(&mut client).await;
    assert_eq!(s["message"], "no channel 99", "{s}");

    request(
        &mut client,
        format!(r#"{{"op":"subscribe","subscriptions":[{{"id":7,"channelId":{state_id}}}]}}"#),
    )
    .await;

    // Bytes and a delete are not bridged; a new JSON key is advertised
    // live; the subscribed key's message arrives as it was sent.
    session
        .put("t/r1/camera/up/frame", vec![0u8, 1, 2])
        .encoding(Encoding::APPLICATION_OCTET_STREAM)
        .await
        .unwrap();
    session.delete("t/r1/state").await.unwrap();
    put("t/r1/scan", r#"{"ranges":[1200,880]}"#).await.unwrap();
    let sent = r#"{"x":3.5,"moving":true}"#;
    put("t/r1/state", sent).await.unwrap();
    let ad = next_text(&mut client).await;
    assert_eq!(ad["op"], "advertise", "{ad}");
    let topics: Vec<&str> = ad["channels"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["topic"].as_str().unwrap())
        .collect();
    assert_eq!(topics, ["t/r1/scan"], "only the new JSON key");
    let Ws::Binary(frame) = next(&mut client).await else {
        panic!("the subscribed message did not come next");
    };
    assert_eq!(frame[0], OP_MESSAGE_DATA);
    assert_eq!(u32::from_le_bytes(frame[1..5].try_into().unwrap()), 7);
    let at_ns = u64::from_le_bytes(frame[5..13].try_into().unwrap());
    assert!(at_ns > 1_600_000_000_000_000_000, "a receive time: {at_ns}");
    assert_eq!(&frame[13..], sent.as_bytes());

    running.stop(client).await;
}

/// A camera's frames bring a picture channel beside them; a picture
/// is asked for when the camera says it grabbed one, and only while a
/// client watches.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_camera_is_seen_in_pictures_fetched_only_while_someone_watches() {
    let session = rome_common::isolated_session().await;
    let png = b"\x89PNG\r\n\x1a\na camera's picture".to_vec();
    let asked = Arc::new(AtomicUsize::new(0));
    let (answer, count) = (png.clone(), asked.clone());
    let _camera = session
        .declare_queryable("t/r1/camera/up/grab")
        .callback(move |q| {
            count.fetch_add(1, Ordering::AcqRel);
            assert!(q.parameters().as_str().contains("format=png"));
            let _ = q
                .reply(q.key_expr().clone(), answer.clone())
                .encoding(Encoding::IMAGE_PNG)
                .wait();
        })
        .await
        .unwrap();
    let bridge = Bridge::start(&session, &["t/**".to_string()])
        .await
        .unwrap();
    let (mut client, running) = connect(bridge).await;
    let frame = |n: u32| {
        session
            .put("t/r1/camera/up/frame", format!(r#"{{"frame":{n}}}"#))
            .encoding(Encoding::APPLICATION_JSON)
    };
    // Handled by the bridge before `put` returns (one session).
    frame(1).await.unwrap();
    let mut ids = BTreeMap::new();
    for _ in 0..2 {
        let ad = next_text(&mut client).await;
        for c in ad["channels"].as_array().unwrap() {
            ids.insert(c["topic"].as_str().unwrap().to_string(), c.clone());
        }
    }
    let image = &ids["t/r1/camera/up/image"];
    assert_eq!(image["schemaName"], "foxglove.CompressedImage");
    assert!(ids.contains_key("t/r1/camera/up/frame"));
    assert_eq!(asked.load(Ordering::Acquire), 0, "nobody watched yet");

    let id = image["id"].as_u64().unwrap();
    request(
        &mut client,
        format!(r#"{{"op":"subscribe","subscriptions":[{{"id":3,"channelId":{id}}}]}}"#),
    )
    .await;
    frame(2).await.unwrap();
    let Ws::Binary(m) = next(&mut client).await else {
        panic!("no picture");
    };
    assert_eq!(u32::from_le_bytes(m[1..5].try_into().unwrap()), 3);
    let picture: Value = serde_json::from_slice(&m[13..]).unwrap();
    assert_eq!(picture["format"], "png");
    assert_eq!(picture["frame_id"], "t/r1/camera/up");
    use base64::Engine;
    let data = base64::engine::general_purpose::STANDARD
        .decode(picture["data"].as_str().unwrap())
        .unwrap();
    assert_eq!(data, png);
    assert!(picture["timestamp"]["sec"].as_u64().unwrap() > 1_600_000_000);
    assert_eq!(asked.load(Ordering::Acquire), 1);

    request(
        &mut client,
        r#"{"op":"unsubscribe","subscriptionIds":[3]}"#.to_string(),
    )
    .await;
    frame(3).await.unwrap();
    assert_eq!(asked.load(Ordering::Acquire), 1, "nobody watches any more");
    running.stop(client).await;
}

/// A request past the size limit ends that client's connection, and
/// the bridge goes on serving the next.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_oversized_request_ends_only_its_own_connection() {
    let session = rome_common::isolated_session().await;
    let bridge = Bridge::start(&session, &["t/**".to_string()])
        .await
        .unwrap();
    let (url, running) = start(bridge).await;
    let mut big = greeted(&url).await;
    let _ = big.send(Ws::text("x".repeat(MAX_REQUEST + 1))).await;
    let ended = tokio::time::timeout(std::time::Duration::from_secs(20), async {
        loop {
            match big.next().await {
                None | Some(Err(_)) | Some(Ok(Ws::Close(_))) => return,
                Some(Ok(_)) => {}
            }
        }
    })
    .await;
    assert!(
        ended.is_ok(),
        "the oversized request's connection stayed open"
    );
    // Greeted as the first was.
    let next_client = greeted(&url).await;
    running.stop(next_client).await;
}

#[test]
fn requests_are_applied_or_refused_with_what_was_wrong() {
    let mut s = Subscribed::default();
    let known = |id: u32| (1..=3).contains(&id);
    assert_eq!(
        s.apply(
            r#"{"op":"subscribe","subscriptions":[{"id":7,"channelId":2},{"id":8,"channelId":2}]}"#,
            known
        ),
        None
    );
    assert_eq!(s.by_channel[&2], vec![7, 8]);
    let (level, m) = s
        .apply(
            r#"{"op":"subscribe","subscriptions":[{"id":7,"channelId":1},{"id":9,"channelId":99}]}"#,
            known,
        )
        .unwrap();
    assert_eq!(level, ERROR);
    assert!(m.contains("subscription 7 is already in use"), "{m}");
    assert!(m.contains("no channel 99"), "{m}");
    let (_, m) = s.apply("not json", known).unwrap();
    assert!(m.contains("cannot take this request"), "{m}");
    let (_, m) = s
        .apply(r#"{"op":"advertise","channels":[]}"#, known)
        .unwrap();
    assert!(m.contains("subscribe and unsubscribe"), "{m}");
    // A number out of u32's range is refused, not wrapped.
    assert!(s
        .apply(
            r#"{"op":"subscribe","subscriptions":[{"id":4294967296,"channelId":1}]}"#,
            known
        )
        .is_some());
    let (_, m) = s
        .apply(r#"{"op":"unsubscribe","subscriptionIds":[8,5]}"#, known)
        .unwrap();
    assert_eq!(m, "no subscription 5");
    assert_eq!(s.by_channel[&2], vec![7]);
    assert_eq!(s.count, 1);
}

#[test]
fn a_subscription_beyond_the_limit_is_refused() {
    let mut s = Subscribed::default();
    let subs: Vec<String> = (0..MAX_SUBSCRIPTIONS as u32 + 2)
        .map(|i| format!(r#"{{"id":{i},"channelId":1}}"#))
        .collect();
    let text = format!(
        r#"{{"op":"subscribe","subscriptions":[{}]}}"#,
        subs.join(",")
    );
    let (_, m) = s.apply(&text, |_| true).unwrap();
    assert_eq!(s.count, MAX_SUBSCRIPTIONS);
    assert!(
        m.contains(&format!("subscription {MAX_SUBSCRIPTIONS} is one more")),
        "{m}"
    );
}

#[test]
fn a_message_frame_is_laid_out_as_the_protocol_says() {
    let Message::Binary(b) = message_frame(0x0102_0304, 5, b"{}") else {
        panic!("not binary");
    };
    assert_eq!(&b[..], &[1, 4, 3, 2, 1, 5, 0, 0, 0, 0, 0, 0, 0, b'{', b'}']);
}
