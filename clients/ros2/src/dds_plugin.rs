//! How Zenoh's ROS 2 DDS plugin (`zenoh-plugin-ros2dds`, as in
//! `rome router --ros2`) learns of a topic on the Zenoh side: a liveliness
//! token per publisher or subscription, which makes the plugin create the
//! DDS writer or reader at once, so ROS 2 nodes on DDS see the topic in
//! their graph before anyone subscribes to it.
//!
//! ```text
//! @/<zid>/@ros2_lv/MP/<key>/<type>/<qos>     a publisher on <key>
//! @/<zid>/@ros2_lv/MS/<key>/<type>/<qos>     a subscription
//! ```
//!
//! From the plugin's `liveliness_mgt.rs` (1.10): `<key>` and `<type>` have
//! each `/` as `§` (`r1§odom`, `nav_msgs§msg§Odometry`); `<qos>` is
//! `<keyed>:<reliability>:<durability>:<history>,<depth>:<user data>`,
//! with `<keyed>` empty for a keyless type (every ROS 2 message), the
//! kinds as CycloneDDS numbers them (reliability best effort 0, reliable
//! 1; durability volatile 0, transient local 1; history keep last 0), and
//! the user data ROS 2 (Iron and later) gives every writer and reader:
//! `typehash=<hash>;`.

use crate::msg::Message;
use crate::rmw_zenoh::{type_hash, Kind, Qos};

/// What stands for `/` in the plugin's tokens.
pub const SLASH: &str = "§";

/// The plugin's token for an entity of session `zid` on Zenoh key `key`
/// carrying `M`.
pub fn token<M: Message>(zid: &str, kind: Kind, key: &str, qos: Qos) -> String {
    let kind = match kind {
        Kind::Publisher => "MP",
        Kind::Subscription => "MS",
        // The plugin announces no nodes of its own kind.
        Kind::Node => "NN",
    };
    let reliability = u8::from(qos.reliable);
    let durability = u8::from(qos.transient_local);
    format!(
        "@/{zid}/@ros2_lv/{kind}/{}/{}/:{reliability}:{durability}:0,{}:typehash={};",
        key.trim_matches('/').replace('/', SLASH),
        M::TYPE.replace('/', SLASH),
        qos.depth,
        type_hash(M::TYPE).unwrap_or_default()
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::{Odometry, Twist};

    #[test]
    fn tokens_follow_the_plugins_layout() {
        assert_eq!(
            token::<Odometry>("abc", Kind::Publisher, "r1/odom", Qos::STREAM),
            "@/abc/@ros2_lv/MP/r1§odom/nav_msgs§msg§Odometry/:1:0:0,5:typehash=RIHS01_3cc97dc7fb7502f8714462c526d369e35b603cfc34d946e3f2eda2766dfec6e0;"
        );
        let sub = token::<Twist>("abc", Kind::Subscription, "fleet/r1/cmd_vel", Qos::COMMAND);
        assert!(
            sub.starts_with("@/abc/@ros2_lv/MS/fleet§r1§cmd_vel/geometry_msgs§msg§Twist/:0:0:0,10:typehash=RIHS01_9c45bf16"),
            "{sub}"
        );
        // Five chunks after the admin prefix, each a valid key chunk.
        assert!(
            zenoh::key_expr::KeyExpr::try_from(sub.clone()).is_ok(),
            "{sub}"
        );
        assert_eq!(sub.split('/').count(), 7, "{sub}");
    }
}
