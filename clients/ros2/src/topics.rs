//! Where the bridge's topics go on Zenoh, in either of the two forms ROS 2
//! meets Zenoh:
//!
//! - [`Form::Dds`]: the key is the topic's name, as Zenoh's ROS 2 DDS
//!   bridge (`zenoh-plugin-ros2dds`) carries it (`/r1/odom` is `r1/odom`),
//!   with the plugin's own liveliness token per topic
//!   ([`crate::dds_plugin`]), so the plugin makes the DDS writer or reader
//!   at once and ROS 2 nodes see the topic before they subscribe.
//! - [`Form::RmwZenoh`]: the key, the liveliness tokens and the sample
//!   attachments of ROS 2's own Zenoh middleware ([`crate::rmw_zenoh`]),
//!   so a node running `rmw_zenoh_cpp` on the same router sees the topics
//!   in its graph and reads them, with no DDS anywhere.

use crate::msg::{self, Message};
use crate::rmw_zenoh::{self, Kind, Node, Qos};
use rome_client::ClientError;
use std::marker::PhantomData;
use std::sync::atomic::{AtomicI64, AtomicU32, Ordering};
use zenoh::bytes::Encoding;
use zenoh::liveliness::LivelinessToken;
use zenoh::Session;

/// The node name the bridge takes in an rmw_zenoh graph.
pub const NODE_NAME: &str = "rome_ros2";

/// How topics meet ROS 2.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Form {
    /// Through Zenoh's ROS 2 DDS bridge: the key is the topic's name.
    Dds,
    /// As rmw_zenoh does, in this ROS domain.
    RmwZenoh {
        /// The ROS domain (`ROS_DOMAIN_ID`).
        domain: u32,
    },
}

/// The bridge's topics on one session.
pub struct Topics {
    session: Session,
    namespace: String,
    /// The session's Zenoh id, as the DDS plugin's tokens write it.
    zid: String,
    /// In the rmw_zenoh form: the bridge's node, and its token.
    node: Option<(Node, LivelinessToken)>,
    next_eid: AtomicU32,
}

impl Topics {
    /// Topics below `namespace` (empty: none) in `form`; in the rmw_zenoh
    /// form the bridge's node is announced at once.
    pub async fn new(
        session: &Session,
        form: Form,
        namespace: &str,
    ) -> Result<Topics, ClientError> {
        let namespace = namespace.to_string();
        let node = match form {
            Form::Dds => None,
            Form::RmwZenoh { domain } => {
                let node = Node {
                    domain,
                    zid_le: session.zid().to_le_bytes(),
                    nid: 0,
                    // The robots' topics carry the namespace themselves.
                    namespace: "/".into(),
                    name: NODE_NAME.into(),
                };
                let token = session
                    .liveliness()
                    .declare_token(node.token())
                    .await
                    .map_err(ClientError::zenoh)?;
                Some((node, token))
            }
        };
        Ok(Topics {
            session: session.clone(),
            zid: session.zid().to_string(),
            namespace,
            node,
            next_eid: AtomicU32::new(1),
        })
    }

    /// The ROS 2 name of `topic` below the namespace, with no leading slash.
    pub fn name(&self, topic: &str) -> String {
        in_namespace(&self.namespace, topic)
    }

    /// The Zenoh key that carries `topic` with messages `M`.
    pub fn key<M: Message>(&self, topic: &str) -> String {
        match &self.node {
            None => self.name(topic),
            Some((node, _)) => rmw_zenoh::topic_key::<M>(node.domain, &self.name(topic)),
        }
    }

    /// Announces an entity on `topic`, returning its token and, in the
    /// rmw_zenoh form, its GID.
    async fn announce<M: Message>(
        &self,
        kind: Kind,
        topic: &str,
        qos: Qos,
    ) -> Result<(LivelinessToken, Option<[u8; 16]>), ClientError> {
        let (token, gid) = match &self.node {
            None => {
                let key = self.name(topic);
                (
                    crate::dds_plugin::token::<M>(&self.zid, kind, &key, qos),
                    None,
                )
            }
            Some((node, _)) => {
                let eid = self.next_eid.fetch_add(1, Ordering::Relaxed);
                // Unique per entity: the session's id with the entity's number.
                let mut gid = node.zid_le;
                gid[12..].copy_from_slice(&eid.to_le_bytes());
                let token = node.entity_token::<M>(eid, kind, &self.name(topic), qos);
                (token, Some(gid))
            }
        };
        let token = self
            .session
            .liveliness()
            .declare_token(token)
            .await
            .map_err(ClientError::zenoh)?;
        Ok((token, gid))
    }

    /// A publisher of `M` on `topic`.
    pub async fn publisher<M: Message>(
        &self,
        topic: &str,
        qos: Qos,
    ) -> Result<Out<M>, ClientError> {
        let publisher = self
            .session
            .declare_publisher(self.key::<M>(topic))
            .encoding(Encoding::APPLICATION_CDR)
            .await
            .map_err(ClientError::zenoh)?;
        let (token, gid) = self.announce::<M>(Kind::Publisher, topic, qos).await?;
        Ok(Out {
            publisher,
            gid,
            seq: AtomicI64::new(0),
            _token: token,
            _message: PhantomData,
        })
    }

    /// A subscriber to `M` on `topic`, and its token, to be kept as long
    /// as it.
    pub async fn subscriber<M: Message>(&self, topic: &str, qos: Qos) -> Result<In, ClientError> {
        let subscriber = self
            .session
            .declare_subscriber(self.key::<M>(topic))
            .await
            .map_err(ClientError::zenoh)?;
        let (token, _) = self.announce::<M>(Kind::Subscription, topic, qos).await?;
        Ok(In {
            subscriber,
            _token: token,
        })
    }
}

/// `name` below the ROS namespace `ns` (empty or `/`: none), with no
/// leading slash.
pub fn in_namespace(ns: &str, name: &str) -> String {
    match ns.trim_matches('/') {
        "" => name.to_string(),
        ns => format!("{ns}/{name}"),
    }
}

/// A subscriber and what announces it.
pub struct In {
    /// The samples.
    pub subscriber:
        zenoh::pubsub::Subscriber<zenoh::handlers::FifoChannelHandler<zenoh::sample::Sample>>,
    _token: LivelinessToken,
}

/// A publisher of one message type, and what announces it.
pub struct Out<M> {
    publisher: zenoh::pubsub::Publisher<'static>,
    /// In the rmw_zenoh form, each sample carries an attachment.
    gid: Option<[u8; 16]>,
    seq: AtomicI64,
    _token: LivelinessToken,
    _message: PhantomData<fn(M)>,
}

impl<M: Message> Out<M> {
    /// Publishes `message`; a failure is logged.
    pub async fn send(&self, message: &M) {
        self.send_bytes(msg::encode(message)).await
    }

    /// Publishes a message already encoded.
    pub async fn send_bytes(&self, payload: Vec<u8>) {
        let put = self.publisher.put(payload);
        let put = match self.gid {
            None => put,
            Some(gid) => {
                let seq = self.seq.fetch_add(1, Ordering::Relaxed) + 1;
                let now = std::time::SystemTime::now()
                    .duration_since(std::time::UNIX_EPOCH)
                    .map_or(0, |d| i64::try_from(d.as_nanos()).unwrap_or(i64::MAX));
                put.attachment(rmw_zenoh::attachment(seq, now, &gid))
            }
        };
        if let Err(e) = put.await {
            tracing::warn!(key = %self.publisher.key_expr(), error = %e, "publication failed");
        }
    }

    /// Whether anyone subscribes now.
    pub async fn wanted(&self) -> bool {
        self.publisher
            .matching_status()
            .await
            .is_ok_and(|m| m.matching())
    }
}
