//! A session's end in words, for messages an operator reads (never Rust debug text).

use super::session::SessionEnd;
use mesopush_protocol::host::TrialEventKind;
use std::fmt;

impl fmt::Display for SessionEnd {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SessionEnd::Accepted { step_count } => {
                write!(f, "the executor accepted the plan ({step_count} steps)")
            }
            SessionEnd::Refused(why) => write!(f, "the executor refused: {why}"),
            SessionEnd::Rejected(r) => write!(f, "{r}"),
            SessionEnd::Trial(TrialEventKind::Started) => write!(f, "the trial started"),
            SessionEnd::Trial(TrialEventKind::Done) => write!(f, "the trial ran to its end"),
            SessionEnd::Trial(TrialEventKind::Aborted) => write!(f, "the trial was aborted"),
            SessionEnd::Trial(TrialEventKind::Faulted(fault)) => {
                write!(f, "the trial faulted: {fault}")
            }
            SessionEnd::Status(s) => write!(
                f,
                "a status report (executor {}, step {} of {})",
                s.state, s.step_index, s.step_count
            ),
            SessionEnd::Motion(m) => write!(f, "{m}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_session_end_reads_as_words_not_as_a_rust_value() {
        let ends = [
            SessionEnd::Accepted { step_count: 7 },
            SessionEnd::Refused("no plan stored".into()),
            SessionEnd::Trial(TrialEventKind::Done),
            SessionEnd::Trial(TrialEventKind::Aborted),
        ];
        for e in ends {
            let s = e.to_string();
            assert!(!s.contains('{') && !s.contains("::") && !s.contains("Trial("), "{s}");
        }
    }
}
