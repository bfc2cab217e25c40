//! Which acknowledged moves have really run: Grbl acknowledges a line when it is queued, so the
//! resume point after a stop comes from the planner blocks a status report says are still in use.

use crate::protocol::{MachineState, Status};

/// The acknowledged moves, and how many of them the last status report left in the planner.
#[derive(Default)]
pub(super) struct Tracker {
    pub(super) planner_blocks: usize,
    pub(super) acked_motion: Vec<usize>,
    pub(super) motion_at_status: usize,
    pub(super) planner_used_at_status: usize,
}

impl Tracker {
    pub(super) fn status(&mut self, st: &Status) {
        self.motion_at_status = self.acked_motion.len();
        self.planner_used_at_status = match (&st.state, st.buffer) {
            (MachineState::Idle, _) => 0,
            (_, Some((free, _))) => self.planner_blocks.saturating_sub(free as usize),
            (_, None) => self.planner_blocks,
        };
    }
    /// The earliest acknowledged move that may not have finished.
    pub(super) fn first_unexecuted(&self) -> Option<usize> {
        let n = self.acked_motion.len();
        let unexec = self.planner_used_at_status + (n - self.motion_at_status.min(n));
        if unexec == 0 || n == 0 {
            None
        } else {
            Some(self.acked_motion[n.saturating_sub(unexec)])
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::protocol::Reply;

    #[test]
    fn tracker_counts_planner_blocks() {
        let mut t = Tracker {
            planner_blocks: 15,
            acked_motion: (1..=20).collect(),
            motion_at_status: 0,
            planner_used_at_status: 0,
        };
        assert_eq!(t.first_unexecuted(), Some(1));
        let mut st = match Reply::parse("<Run|MPos:0,0,0|Bf:12,100>") {
            Reply::Status(s) => s,
            _ => unreachable!(),
        };
        t.status(&st);
        assert_eq!(t.first_unexecuted(), Some(18));
        t.acked_motion.push(21);
        assert_eq!(t.first_unexecuted(), Some(18));
        st.state = MachineState::Idle;
        t.status(&st);
        assert_eq!(t.first_unexecuted(), None);
        st.state = MachineState::Hold(0);
        st.buffer = None;
        t.status(&st);
        assert_eq!(t.first_unexecuted(), Some(7));
    }
}
