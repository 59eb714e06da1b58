//! SPEC §5 — being written.
use super::{Command, Snapshot, TargetMemory};
use rand::Rng;
pub fn escape_command<R: Rng>(_j: usize, _snap: &Snapshot, _mem: &mut TargetMemory, _rng: &mut R) -> Command {
    unimplemented!("escape law")
}
pub fn random_command<R: Rng>(_j: usize, _snap: &Snapshot, _mem: &mut TargetMemory, _rng: &mut R) -> Command {
    unimplemented!("random law")
}
