//! Which branch of its law decided an agent's command in a step: one vocabulary for every law
//! (docs/world-and-laws.md §3–§7 name the branches), recorded per agent and step
//! (`World::wolf_mode`, the trajectory's `wolf_mode` / `target_mode`) for the reader of an
//! episode. An output only: no law reads a mode back, so recording it changes no number.

/// The mode of an agent's law in one step, as a small code (`as u8`) with a name
/// ([`LawMode::name`]). The codes are stable: new modes are added at the end.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[repr(u8)]
pub enum LawMode {
    /// No law decided: given commands (a learned model) drove the agent, or no step has been
    /// taken yet (row 0 of a trajectory).
    #[default]
    None = 0,
    /// seed000 (§3.1, case 1): the wolf senses its target and is drawn to the hunting ring.
    Chase = 1,
    /// seed000 (§3.1, case 2): follows the nearest wolf that senses the target.
    Follow = 2,
    /// Nobody in the pack senses the wolf's target now: seed000 keeps its last attraction's
    /// direction (§3.1, case 3), bvc heads for the hunting points around the last sighting (§6),
    /// formation for where the target would be had it kept going (§7.1).
    Lost = 3,
    /// bvc, formation: the target has never been sensed; the wolf stands.
    Wait = 4,
    /// Avoidance (§4.4.1): skipped, a capture being under way at the wolf's target (or the only
    /// item a wall); the attraction goes straight to the saturator.
    EarlyExit = 5,
    /// Avoidance (§4.5): fleeing a danger interval closer than the danger distance.
    Emergency = 6,
    /// Avoidance (§4.6): steering away from partners close ahead.
    ClosePartner = 7,
    /// Avoidance, normal mode (§4.7, §4.8): the desired heading lay in a danger interval and
    /// was moved to its nearer edge.
    AvoidEdge = 8,
    /// Avoidance, target variant (§4.8): turning towards the desired heading would enter a
    /// danger interval, so the target keeps its heading.
    AvoidHold = 9,
    /// bvc (§6): nothing within `bvc.d_min`; straight for the hunting point.
    Direct = 10,
    /// bvc (§6): near an obstacle or wolf, and the hunting point lies in the wolf's cell.
    CellInside = 11,
    /// bvc (§6): the goal is the closest point of the cell, on an edge.
    CellEdge = 12,
    /// bvc (§6): the goal is the closest point of the cell, a vertex.
    CellVertex = 13,
    /// formation (§7.1): the slot around the virtual leader, `formation.lead` metres along its
    /// path towards the target.
    Lead = 14,
    /// formation (§7.1): the path is shorter than `formation.lead`; the leader is the target
    /// and the slots ring it.
    Encircle = 15,
    /// escape before its first sighting of a wolf, and random always (§5.1, §5.3): wander.
    Wander = 16,
    /// escape (§5.1): flees the wolves it senses, at the fatigue curve's speed.
    Flee = 17,
    /// escape (§5.1): has seen wolves but senses none now; keeps its heading, slowing with the
    /// fatigue curve.
    Coast = 18,
    /// still (§5.3): stands.
    Still = 19,
    /// Any target law: the target's hunt has ended (captured or cornered); it stands.
    Ended = 20,
}

impl LawMode {
    /// Every mode, in code order: `ALL[k] as u8 == k`.
    pub const ALL: [LawMode; 21] = [
        Self::None,
        Self::Chase,
        Self::Follow,
        Self::Lost,
        Self::Wait,
        Self::EarlyExit,
        Self::Emergency,
        Self::ClosePartner,
        Self::AvoidEdge,
        Self::AvoidHold,
        Self::Direct,
        Self::CellInside,
        Self::CellEdge,
        Self::CellVertex,
        Self::Lead,
        Self::Encircle,
        Self::Wander,
        Self::Flee,
        Self::Coast,
        Self::Still,
        Self::Ended,
    ];

    /// The mode's name, as the trajectory's `mode_names` and the viewer show it.
    pub const fn name(self) -> &'static str {
        match self {
            Self::None => "none",
            Self::Chase => "chase",
            Self::Follow => "follow",
            Self::Lost => "lost",
            Self::Wait => "wait",
            Self::EarlyExit => "early_exit",
            Self::Emergency => "emergency",
            Self::ClosePartner => "close_partner",
            Self::AvoidEdge => "avoid_edge",
            Self::AvoidHold => "avoid_hold",
            Self::Direct => "direct",
            Self::CellInside => "cell_inside",
            Self::CellEdge => "cell_edge",
            Self::CellVertex => "cell_vertex",
            Self::Lead => "lead",
            Self::Encircle => "encircle",
            Self::Wander => "wander",
            Self::Flee => "flee",
            Self::Coast => "coast",
            Self::Still => "still",
            Self::Ended => "ended",
        }
    }

    /// The names of every code, indexed by code.
    pub const NAMES: [&'static str; 21] = {
        let mut out = [""; 21];
        let mut k = 0;
        while k < 21 {
            out[k] = Self::ALL[k].name();
            k += 1;
        }
        out
    };

    /// The mode of code `code`, if any.
    pub fn from_code(code: u8) -> Option<Self> {
        Self::ALL.get(code as usize).copied()
    }
}

#[cfg(test)]
mod tests {
    use super::LawMode;

    #[test]
    fn codes_index_the_table_and_names_are_unique() {
        for (k, m) in LawMode::ALL.iter().enumerate() {
            assert_eq!(*m as u8 as usize, k, "{m:?}");
            assert_eq!(LawMode::from_code(k as u8), Some(*m));
            assert_eq!(LawMode::NAMES[k], m.name());
        }
        assert_eq!(LawMode::from_code(LawMode::ALL.len() as u8), None);
        let mut names = LawMode::NAMES.to_vec();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), LawMode::ALL.len());
        assert!(LawMode::NAMES.iter().all(|n| !n.is_empty() && n.chars().all(|c| c.is_ascii_lowercase() || c == '_')));
    }
}
