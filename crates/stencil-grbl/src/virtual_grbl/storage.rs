//! What the card of the virtual board holds: its files, a file arriving, the job it runs (the
//! card's behaviour is in `card`).

use std::collections::BTreeMap;

/// A file arriving over the stream.
pub(super) struct Upload {
    /// FluidNC names it in its command; grblHAL's YModem in its packet 0.
    pub(super) name: Option<String>,
    pub(super) ymodem: bool,
    /// The size YModem's packet 0 gives (the last packet's padding is cut to it).
    pub(super) size: Option<usize>,
    pub(super) data: Vec<u8>,
    pub(super) packet: Vec<u8>,
    pub(super) next: u8,
    /// FluidNC's command line, answered once the transfer is over.
    pub(super) answer: Option<usize>,
}

/// The job the board runs from its card.
pub(super) struct CardRun {
    pub(super) name: String,
    pub(super) size: usize,
}

/// The files on the card, by name.
pub(super) type Card = BTreeMap<String, Vec<u8>>;
