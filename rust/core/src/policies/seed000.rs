//! SPEC §3 — being written.
use super::{Command, Snapshot, WolfMemory};
pub fn wolf_command(_i: usize, _snap: &Snapshot, _mem: &mut WolfMemory, _row: &mut [u8]) -> Command {
    unimplemented!("seed000 law")
}
