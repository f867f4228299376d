//! Tests of `record`.

use super::*;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn images_are_kept_as_they_came_and_deletes_as_deletes() {
    let session = rome_common::isolated_session().await;
    let dir = std::env::temp_dir().join(format!("rome-rec-unit-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("x.mcap");
    let rec = Recorder::start(&session, &["t/**".to_string()], &path, false)
        .await
        .unwrap();
    let png = b"\x89PNG\r\n\x1a\nnot really".to_vec();
    session
        .put("t/cam", png.clone())
        .encoding(Encoding::IMAGE_PNG)
        .await
        .unwrap();
    session
        .put("t/v", r#"{"a":1}"#)
        .encoding(Encoding::APPLICATION_JSON)
        .await
        .unwrap();
    session.delete("t/v").await.unwrap();
    // Local puts reach the subscriber before `put` returns; stop()
    // writes out what it heard.
    let summary = rec.stop().await.unwrap();
    assert_eq!(summary.messages, 3);
    let m = crate::replay::load(&path).unwrap();
    assert_eq!(m[0].key, "t/cam");
    assert_eq!(m[0].data, png);
    assert_eq!(m[0].encoding, Encoding::IMAGE_PNG);
    assert!(!m[1].delete && m[2].delete);
    let buf = std::fs::read(&path).unwrap();
    let encodings: Vec<(String, String)> = mcap::MessageStream::new(&buf)
        .unwrap()
        .map(|m| {
            let m = m.unwrap();
            (m.channel.topic.clone(), m.channel.message_encoding.clone())
        })
        .collect();
    assert_eq!(encodings[0], ("t/cam".into(), "image/png".into()));
    assert_eq!(encodings[1], ("t/v".into(), "json".into()));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_schema_describes_the_message_it_came_from() {
    let v: serde_json::Value =
        serde_json::from_str(r#"{"x":1.5,"robot":"r1","lock":null,"s":[1,2],"o":{"b":true}}"#)
            .unwrap();
    let s = json_schema(&v);
    assert_eq!(s["type"], "object");
    assert_eq!(s["properties"]["x"]["type"], "number");
    assert_eq!(s["properties"]["robot"]["type"], "string");
    assert_eq!(s["properties"]["lock"], serde_json::json!({}));
    assert_eq!(s["properties"]["s"]["items"]["type"], "number");
    assert_eq!(s["properties"]["o"]["properties"]["b"]["type"], "boolean");
    assert_eq!(schema_name("rome/robot/r1/base/state"), "rome.BaseState");
}
