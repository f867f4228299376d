use super::*;
use crate::msg::{Image, LaserScan, OccupancyGrid, Odometry, Twist};

/// The hashes ROS 2 Jazzy's message packages publish for these types
/// (`share/<package>/msg/<Type>.json`, `type_hashes`).
const JAZZY: &[(&str, &str)] = &[
    (
        "builtin_interfaces/msg/Time",
        "RIHS01_b106235e25a4c5ed35098aa0a61a3ee9c9b18d197f398b0e4206cea9acf9c197",
    ),
    (
        "std_msgs/msg/Header",
        "RIHS01_f49fb3ae2cf070f793645ff749683ac6b06203e41c891e17701b1cb597ce6a01",
    ),
    (
        "geometry_msgs/msg/Twist",
        "RIHS01_9c45bf16fe0983d80e3cfe750d6835843d265a9a6c46bd2e609fcddde6fb8d2a",
    ),
    (
        "nav_msgs/msg/Odometry",
        "RIHS01_3cc97dc7fb7502f8714462c526d369e35b603cfc34d946e3f2eda2766dfec6e0",
    ),
    (
        "sensor_msgs/msg/LaserScan",
        "RIHS01_64c191398013af96509d518dac71d5164f9382553fce5c1f8cca5be7924bd828",
    ),
    (
        "sensor_msgs/msg/Image",
        "RIHS01_d31d41a9a4c4bc8eae9be757b0beed306564f7526c88ea6a4588fb9582527d47",
    ),
    (
        "nav_msgs/msg/OccupancyGrid",
        "RIHS01_8d348150c12913a31ee0ec170fbf25089e4745d17035792a1ba94d6f0bc0cfc7",
    ),
];

#[test]
fn type_hashes_computed_from_the_descriptions_are_those_ros_2_publishes() {
    for (ros_type, published) in JAZZY {
        assert_eq!(
            type_hash(ros_type).as_deref(),
            Some(*published),
            "{ros_type}"
        );
    }
    // Every message the bridge speaks has its hash.
    for t in [
        Odometry::TYPE,
        LaserScan::TYPE,
        Image::TYPE,
        Twist::TYPE,
        OccupancyGrid::TYPE,
    ] {
        assert!(JAZZY.iter().any(|(n, _)| *n == t), "{t}");
    }
}

#[test]
fn a_description_one_field_off_hashes_otherwise() {
    // The hash covers every field's type: float32 where float64 stands
    // is another type.
    let twist = fields_of("geometry_msgs/msg/Vector3").unwrap();
    let mut changed: Vec<Field> = twist.to_vec();
    changed[0].1 = field_type::FLOAT;
    assert_ne!(
        description_json("geometry_msgs/msg/Vector3", twist),
        description_json("geometry_msgs/msg/Vector3", &changed)
    );
    assert_eq!(type_hash("geometry_msgs/msg/Wrench"), None);
}

#[test]
fn dds_type_names_are_mangled_as_rmw_zenoh_writes_them() {
    assert_eq!(
        dds_type_name("nav_msgs/msg/Odometry").as_deref(),
        Some("nav_msgs::msg::dds_::Odometry_")
    );
    assert_eq!(dds_type_name("Odometry"), None);
    assert_eq!(dds_type_name("a/b/c/d"), None);
    assert_eq!(dds_type_name("nav_msgs//Odometry"), None);
}

#[test]
fn a_topic_key_is_domain_name_type_and_hash() {
    assert_eq!(
        topic_key::<Odometry>(0, "/r1/odom"),
        "0/r1/odom/nav_msgs::msg::dds_::Odometry_/RIHS01_3cc97dc7fb7502f8714462c526d369e35b603cfc34d946e3f2eda2766dfec6e0"
    );
    assert!(topic_key::<Twist>(7, "fleet/r2/cmd_vel/")
        .starts_with("7/fleet/r2/cmd_vel/geometry_msgs::msg::dds_::Twist_/RIHS01_9c45bf16"));
}

#[test]
fn a_zid_is_written_as_zenoh_writes_it() {
    let mut zid = [0u8; 16];
    zid[0] = 0x01;
    zid[1] = 0xab;
    zid[15] = 0x0f;
    // One number, most significant byte first, no leading zeros.
    assert_eq!(zid_text(&zid), format!("f{}ab01", "0".repeat(26)));
    let id = zenoh::session::ZenohId::default();
    assert_eq!(zid_text(&id.to_le_bytes()), id.to_string());
}

#[test]
fn qos_chunks_say_reliability_durability_and_depth() {
    assert_eq!(Qos::DEFAULT.to_key(), "1:2:1,10:,:,:,,");
    assert_eq!(Qos::STREAM.to_key(), "1:2:1,5:,:,:,,");
    assert_eq!(Qos::COMMAND.to_key(), "2:2:1,10:,:,:,,");
    assert_eq!(Qos::MAP.to_key(), "1:1:1,1:,:,:,,");
}

fn node() -> Node {
    let mut zid_le = [0u8; 16];
    zid_le[0] = 0x2a;
    Node {
        domain: 0,
        zid_le,
        nid: 3,
        namespace: "/".into(),
        name: "rome_ros2".into(),
    }
}

#[test]
fn tokens_follow_the_liveliness_layout() {
    let n = node();
    let zid = "2a";
    assert_eq!(n.token(), format!("@ros2_lv/0/{zid}/3/3/NN/%/%/rome_ros2"));
    let publisher = n.entity_token::<Odometry>(12, Kind::Publisher, "/r1/odom", Qos::STREAM);
    assert_eq!(
        publisher,
        format!(
            "@ros2_lv/0/{zid}/3/12/MP/%/%/rome_ros2/%r1%odom/nav_msgs::msg::dds_::Odometry_/{}/1:2:1,5:,:,:,,",
            JAZZY[3].1
        )
    );
    let reader = n.entity_token::<Twist>(13, Kind::Subscription, "r1/cmd_vel", Qos::COMMAND);
    let parts: Vec<&str> = reader.split('/').collect();
    // Admin space … QoS: thirteen chunks, none empty (a key cannot have one).
    assert_eq!(parts.len(), 13, "{reader}");
    assert!(parts.iter().all(|p| !p.is_empty()), "{reader}");
    assert_eq!(parts[5], "MS");
    assert_eq!(parts[9], "%r1%cmd_vel");
    let fleet = Node {
        namespace: "fleet".into(),
        ..node()
    };
    assert!(
        fleet.token().ends_with("/NN/%/%fleet/rome_ros2"),
        "{}",
        fleet.token()
    );
    // Every token is a valid key expression.
    for t in [n.token(), publisher, reader, fleet.token()] {
        assert!(zenoh::key_expr::KeyExpr::try_from(t.clone()).is_ok(), "{t}");
    }
}

#[test]
fn the_attachment_is_what_zenoh_ext_serializes() {
    let gid: [u8; 16] = std::array::from_fn(|i| i as u8 * 3);
    let ours = attachment(41, -7, &gid);
    let theirs = zenoh_ext::z_serialize(&(41i64, -7i64, gid))
        .to_bytes()
        .to_vec();
    assert_eq!(ours, theirs);
    assert_eq!(ours.len(), 33);
}
