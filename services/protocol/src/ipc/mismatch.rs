//! Why a topic's service that exists cannot be opened with the stack's settings: another
//! process created it with settings of its own (a smaller subscriber buffer, another
//! payload type, …), and iceoryx2 refuses it. [`incompatible`] names the first setting that
//! falls short and what the stack needs, from the service's own record.

use super::Service;
use crate::topics::{self, Topic};
use iceoryx2::prelude::*;
use iceoryx2::service::Service as _;
use iceoryx2::service::messaging_pattern::MessagingPattern;
use iceoryx2::service::static_config::message_type_details::{TypeDetail, TypeVariant};

/// What the stack needs of a topic's service: its settings and its message types.
pub(super) struct Needed<'a> {
    /// The topic's settings.
    pub topic: &'a Topic,
    /// The payload type (for a slice topic, its element).
    pub payload: TypeDetail,
    /// The user header type.
    pub user_header: TypeDetail,
}

/// The existing publish–subscribe service `name` of the stack `config`, when one of its
/// settings falls short of `needed`: one sentence naming the setting, its value, what the
/// stack needs, and what to do. `None` when there is no such service or nothing falls
/// short (then iceoryx2's own error stands).
pub(super) fn incompatible(
    name: &ServiceName,
    config: &iceoryx2::config::Config,
    needed: &Needed<'_>,
) -> Option<String> {
    let details = Service::details(name, config, MessagingPattern::PublishSubscribe).ok()??;
    let found = details.static_details.publish_subscribe();
    let types = found.message_type_details();
    let at_least = |what: &str, has: usize, needs: usize| {
        (has < needs).then(|| format!("{what} {has}; the stack needs at least {needs}"))
    };
    let same_type = |what: &str, has: &TypeDetail, needs: &TypeDetail| {
        (has != needs).then(|| format!("{what} {}; the stack needs {}", show(has), show(needs)))
    };
    let lacking = same_type("payload type", &types.payload, &needed.payload)
        .or_else(|| same_type("user header", &types.user_header, &needed.user_header))
        .or_else(|| {
            let buffer = found.subscriber_max_buffer_size();
            at_least("subscriber buffer", buffer, needed.topic.buffer)
        })
        .or_else(|| at_least("history", found.history_size(), needed.topic.history))
        .or_else(|| {
            let publishers = found.max_publishers();
            at_least("max publishers", publishers, topics::MAX_PUBLISHERS)
        })
        .or_else(|| {
            let subscribers = found.max_subscribers();
            at_least("max subscribers", subscribers, topics::MAX_SUBSCRIBERS)
        })
        .or_else(|| {
            (found.has_safe_overflow())
                .then(|| "safe overflow on; the stack needs it off".to_string())
        })?;
    Some(format!(
        "service {} exists with {lacking}: stop the process that created it (the protocol \
         README lists every topic's settings)",
        name.as_str()
    ))
}

/// A type as the protocol README's type table names it: name, size, alignment, and
/// whether it is a slice's element.
fn show(t: &TypeDetail) -> String {
    let slice = match t.variant() {
        TypeVariant::Dynamic => " (slice)",
        TypeVariant::FixedSize => "",
    };
    format!(
        "`{}`{slice}, {} bytes aligned to {}",
        t.type_name(),
        t.size(),
        t.alignment()
    )
}

#[cfg(test)]
mod tests {
    use super::super::testing::{TestStack, on_thread};
    use super::super::{Ipc, Result, iox_err};
    use crate::{PoseEstimate, topics};

    /// Creates the stack's `pose` service the way a process of one's own might, with
    /// `buffer`, safe overflow `overflow` and payload `P`, then opens it as the stack
    /// does.
    fn open_after<P: std::fmt::Debug + iceoryx2::prelude::ZeroCopySend + 'static>(
        tag: &str,
        buffer: usize,
        overflow: bool,
    ) -> std::result::Result<(), String> {
        let test = TestStack::new(tag);
        on_thread(
            test.config(),
            "opening hangs",
            move |ipc: &Ipc| -> Result<()> {
                let name = topics::service_name(&ipc.prefix, topics::POSE.name);
                let name = iceoryx2::prelude::ServiceName::new(&name).map_err(iox_err("name"))?;
                let _theirs = ipc
                    .node()
                    .service_builder(&name)
                    .publish_subscribe::<P>()
                    .subscriber_max_buffer_size(buffer)
                    .enable_safe_overflow(overflow)
                    .max_publishers(topics::MAX_PUBLISHERS)
                    .max_subscribers(topics::MAX_SUBSCRIBERS)
                    .create()
                    .map_err(iox_err("create"))?;
                ipc.publisher::<PoseEstimate>(&topics::POSE).map(|_| ())
            },
        )
    }

    #[test]
    fn a_service_created_with_a_smaller_buffer_is_refused_naming_the_buffer() {
        let refused = open_after::<PoseEstimate>("mmbuf", 16, false).unwrap_err();
        assert!(
            refused
                .contains("/pose exists with subscriber buffer 16; the stack needs at least 256"),
            "{refused}"
        );
        assert_eq!(refused.lines().count(), 1, "{refused}");
    }

    #[test]
    fn a_service_created_with_another_payload_is_refused_naming_both_types() {
        let refused = open_after::<u64>("mmtype", 256, false).unwrap_err();
        assert!(
            refused.contains("payload type `u64`")
                && refused.contains("needs `fastslam::PoseEstimate`, 112 bytes aligned to 8"),
            "{refused}"
        );
    }

    #[test]
    fn a_service_created_with_safe_overflow_is_refused_naming_it() {
        let refused = open_after::<PoseEstimate>("mmovf", 256, true).unwrap_err();
        assert!(
            refused.contains("exists with safe overflow on; the stack needs it off"),
            "{refused}"
        );
    }

    #[test]
    fn a_service_with_the_stacks_settings_opens() {
        assert_eq!(open_after::<PoseEstimate>("mmok", 256, false), Ok(()));
    }
}
