//! The rules that tie rows, groups (targets, planes) and sessions (set-ups) of contact data
//! together, checked once here for every front end (the measurement reader of `kincal-io`
//! and the C ABI): a target or plane is a fixed point of one set-up, so all its rows lie in
//! one session; instrument rows lie in one session, or — when the caller gives each session
//! a frame of its own ([`SessionLayout::instrument_frames`]) — every session but the first
//! with instrument rows holds at least [`MIN_FRAME_ROWS`] of them; a session holds at least
//! [`MIN_SESSION_ROWS`] rows; a group holds at least the contacts its kind
//! needs ([`GroupKind::min_contacts`]). No heap: the caller lends the counters.
//!
//! The front ends word the refusal ([`SessionFault`] names the row and the group or session
//! by index); they map indices to their ids (strings in a file, integers in C).

use super::constraints::{GroupKind, MIN_SESSION_ROWS};

/// "No row" in [`SessionFault`] (a group no row names).
pub const NO_ROW: usize = usize::MAX;

/// Instrument rows a session with a frame of its own needs: three positions not on a line
/// fix a rigid frame (fewer leave it undetermined; the core then fails with
/// `Error::RankDeficient`).
pub const MIN_FRAME_ROWS: usize = 3;

/// What one row of contact data is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RowRole {
    /// An instrument row (coordinates of the tool point, full or partial).
    Instrument,
    /// A contact of group `g` (the caller's index: targets and planes alike).
    Contact(usize),
}

/// The first rule the data break: an index out of range (in row order), then a session
/// that is too small, then a row in the wrong session (the first in row order), then a
/// group that is too small. Rows, groups and sessions are the caller's zero-based indices.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SessionFault {
    /// A row names a session not below the number of sessions.
    SessionOutOfRange {
        /// The row.
        row: usize,
        /// The session it names.
        session: usize,
    },
    /// A contact names a group not below the number of groups.
    GroupOutOfRange {
        /// The row.
        row: usize,
        /// The group it names.
        group: usize,
    },
    /// A contact lies in another session than its group's first row.
    GroupInTwoSessions {
        /// The group.
        group: usize,
        /// The row in the other session.
        row: usize,
        /// The group's first row.
        first: usize,
    },
    /// An instrument row lies in another session than the first instrument row, and the
    /// caller has one base frame for all instrument rows (no
    /// [`SessionLayout::instrument_frames`]).
    InstrumentInTwoSessions {
        /// The row in the other session.
        row: usize,
        /// The first instrument row.
        first: usize,
    },
    /// A session with a frame of its own holds fewer than [`MIN_FRAME_ROWS`] instrument
    /// rows (with [`SessionLayout::instrument_frames`]).
    FrameTooSmall {
        /// The session.
        session: usize,
        /// Its instrument rows.
        rows: usize,
        /// Its first instrument row.
        first: usize,
    },
    /// A session has fewer than [`MIN_SESSION_ROWS`] rows.
    SessionTooSmall {
        /// The session.
        session: usize,
        /// Its rows.
        rows: usize,
        /// Its first row.
        first: usize,
    },
    /// A group has fewer contacts than its kind needs.
    GroupTooSmall {
        /// The group.
        group: usize,
        /// Its contacts.
        rows: usize,
        /// Contacts needed ([`GroupKind::min_contacts`]).
        needed: usize,
        /// Its first row ([`NO_ROW`] when none).
        first: usize,
    },
    /// The counters lent are shorter than the groups or sessions they must count.
    ScratchTooSmall,
}

/// Counters lent by the caller: `groups` entries for each group, `sessions` for each
/// session (contents on entry are ignored).
#[derive(Debug)]
pub struct SessionScratch<'a> {
    /// Rows per group.
    pub group_rows: &'a mut [usize],
    /// First row of each group.
    pub group_first: &'a mut [usize],
    /// Session of each group (of its first row).
    pub group_session: &'a mut [usize],
    /// Rows per session.
    pub session_rows: &'a mut [usize],
    /// First row of each session.
    pub session_first: &'a mut [usize],
}

/// The groups and sessions of the data, for [`check_sessions`].
#[derive(Debug, Clone, Copy)]
pub struct SessionLayout {
    /// Number of groups (targets and planes; rows name groups `0..n_groups`).
    pub n_groups: usize,
    /// Number of sessions (rows name sessions `0..n_sessions`).
    pub n_sessions: usize,
    /// Whether the data names sessions at all: without, all rows are one set-up and its
    /// size is not checked (a data set without sessions is not refused for being small).
    pub sessions_given: bool,
    /// Whether the caller fits a frame per session for instrument rows (the first session
    /// with instrument rows in the robot's base frame, each later one in a frame of its own,
    /// `identify::InstrumentSession`): instrument rows may then span sessions, and each
    /// later session needs [`MIN_FRAME_ROWS`] of them. Without, instrument rows in two
    /// sessions are refused.
    pub instrument_frames: bool,
}

/// Checks the rows (`(role, session)` in row order) against the session and group rules;
/// `kind_of(g)` is the kind of group `g`. Errors: the first [`SessionFault`] in the order
/// documented there.
pub fn check_sessions<I>(
    rows: I,
    kind_of: impl Fn(usize) -> GroupKind,
    layout: &SessionLayout,
    scratch: SessionScratch<'_>,
) -> Result<(), SessionFault>
where
    I: IntoIterator<Item = (RowRole, usize)>,
    I::IntoIter: Clone,
{
    let rows = rows.into_iter();
    let again = rows.clone();
    let SessionScratch {
        group_rows,
        group_first,
        group_session,
        session_rows,
        session_first,
    } = scratch;
    let n_groups = layout.n_groups;
    let (group_rows, group_first, group_session) = match (
        group_rows.get_mut(..n_groups),
        group_first.get_mut(..n_groups),
        group_session.get_mut(..n_groups),
    ) {
        (Some(a), Some(b), Some(c)) => (a, b, c),
        _ => return Err(SessionFault::ScratchTooSmall),
    };
    let (session_rows, session_first) = match (
        session_rows.get_mut(..layout.n_sessions),
        session_first.get_mut(..layout.n_sessions),
    ) {
        (Some(a), Some(b)) => (a, b),
        _ => return Err(SessionFault::ScratchTooSmall),
    };
    group_rows.fill(0);
    group_first.fill(NO_ROW);
    group_session.fill(0);
    session_rows.fill(0);
    session_first.fill(NO_ROW);
    let mut instrument: Option<(usize, usize)> = None;
    // The first row that breaks a session rule; reported after the session sizes (a row
    // moved to a session of its own is first of all a session that is too small).
    let mut row_fault: Option<SessionFault> = None;
    for (row, (role, session)) in rows.into_iter().enumerate() {
        let (Some(count), Some(first)) = (
            session_rows.get_mut(session),
            session_first.get_mut(session),
        ) else {
            return Err(SessionFault::SessionOutOfRange { row, session });
        };
        *count += 1;
        if *first == NO_ROW {
            *first = row;
        }
        match role {
            RowRole::Contact(group) => {
                let (Some(count), Some(first), Some(in_session)) = (
                    group_rows.get_mut(group),
                    group_first.get_mut(group),
                    group_session.get_mut(group),
                ) else {
                    return Err(SessionFault::GroupOutOfRange { row, group });
                };
                if *count == 0 {
                    *first = row;
                    *in_session = session;
                } else if *in_session != session && row_fault.is_none() {
                    row_fault = Some(SessionFault::GroupInTwoSessions {
                        group,
                        row,
                        first: *first,
                    });
                }
                *count += 1;
            }
            RowRole::Instrument => match instrument {
                None => instrument = Some((row, session)),
                Some((first, s))
                    if s != session && row_fault.is_none() && !layout.instrument_frames =>
                {
                    row_fault = Some(SessionFault::InstrumentInTwoSessions { row, first });
                }
                Some(_) => {}
            },
        }
    }
    if layout.sessions_given {
        let sizes = session_rows.iter().zip(session_first.iter());
        if let Some((session, (&rows, &first))) = sizes
            .enumerate()
            .find(|(_, (n, _))| **n > 0 && **n < MIN_SESSION_ROWS)
        {
            return Err(SessionFault::SessionTooSmall {
                session,
                rows,
                first,
            });
        }
    }
    if let Some(fault) = row_fault {
        return Err(fault);
    }
    if let (true, Some((_, base))) = (layout.instrument_frames, instrument) {
        // The session counters are free again: instrument rows per session.
        session_rows.fill(0);
        session_first.fill(NO_ROW);
        for (row, (role, session)) in again.enumerate() {
            if let (RowRole::Instrument, Some(n), Some(f)) = (
                role,
                session_rows.get_mut(session),
                session_first.get_mut(session),
            ) {
                *n += 1;
                if *f == NO_ROW {
                    *f = row;
                }
            }
        }
        let counts = session_rows.iter().zip(session_first.iter()).enumerate();
        for (session, (&rows, &first)) in counts {
            if session != base && rows > 0 && rows < MIN_FRAME_ROWS {
                return Err(SessionFault::FrameTooSmall {
                    session,
                    rows,
                    first,
                });
            }
        }
    }
    let groups = group_rows.iter().zip(group_first.iter()).enumerate();
    for (group, (&rows, &first)) in groups {
        let needed = kind_of(group).min_contacts();
        if rows < needed {
            return Err(SessionFault::GroupTooSmall {
                group,
                rows,
                needed,
                first,
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const T: GroupKind = GroupKind::Target;
    const P: GroupKind = GroupKind::Plane;

    fn check(
        rows: &[(RowRole, usize)],
        kinds: &[GroupKind],
        sessions: usize,
    ) -> Result<(), SessionFault> {
        let mut a = [0usize; 8];
        let mut b = [0usize; 8];
        let mut c = [0usize; 8];
        let mut d = [0usize; 8];
        let mut e = [0usize; 8];
        check_sessions(
            rows.iter().copied(),
            |g| kinds[g],
            &SessionLayout {
                n_groups: kinds.len(),
                n_sessions: sessions,
                sessions_given: true,
                instrument_frames: false,
            },
            SessionScratch {
                group_rows: &mut a,
                group_first: &mut b,
                group_session: &mut c,
                session_rows: &mut d,
                session_first: &mut e,
            },
        )
    }

    use RowRole::{Contact as C, Instrument as I};

    #[test]
    fn good_rows_pass() {
        let rows = [
            (C(0), 0),
            (C(1), 1),
            (C(0), 0),
            (C(1), 1),
            (C(1), 1),
            (I, 0),
            (C(2), 1),
        ];
        assert_eq!(
            check(&rows, &[T, P, GroupKind::KnownTarget([0.0; 3])], 2),
            Ok(())
        );
    }

    #[test]
    fn each_rule_names_its_row_group_or_session() {
        let two = [
            (C(0), 0),
            (C(0), 0),
            (C(0), 0),
            (C(0), 1),
            (C(0), 1),
            (C(0), 1),
        ];
        assert_eq!(
            check(&two, &[T], 2),
            Err(SessionFault::GroupInTwoSessions {
                group: 0,
                row: 3,
                first: 0
            })
        );
        let inst = [(I, 0), (I, 0), (I, 0), (I, 1), (I, 1), (I, 1)];
        assert_eq!(
            check(&inst, &[], 2),
            Err(SessionFault::InstrumentInTwoSessions { row: 3, first: 0 })
        );
        let small = [(C(0), 0), (C(0), 0), (C(0), 0), (I, 1), (C(0), 0)];
        assert_eq!(
            check(&small, &[T], 2),
            Err(SessionFault::SessionTooSmall {
                session: 1,
                rows: 1,
                first: 3
            })
        );
        // A contact moved to a session of its own: first of all a session too small.
        let moved = [(C(0), 0), (C(0), 0), (C(0), 1), (C(0), 0)];
        assert_eq!(
            check(&moved, &[T], 2),
            Err(SessionFault::SessionTooSmall {
                session: 1,
                rows: 1,
                first: 2
            })
        );
        let few = [(C(0), 0), (C(1), 0), (C(1), 0), (C(1), 0)];
        assert_eq!(
            check(&few, &[T, P, T], 1),
            Err(SessionFault::GroupTooSmall {
                group: 0,
                rows: 1,
                needed: 2,
                first: 0
            })
        );
        let unused = [(C(0), 0), (C(0), 0), (C(0), 0)];
        assert_eq!(
            check(&unused, &[T, GroupKind::KnownTarget([0.0; 3])], 1),
            Err(SessionFault::GroupTooSmall {
                group: 1,
                rows: 0,
                needed: 1,
                first: NO_ROW
            })
        );
        assert_eq!(
            check(&[(I, 3)], &[], 2),
            Err(SessionFault::SessionOutOfRange { row: 0, session: 3 })
        );
        assert_eq!(
            check(&[(C(5), 0)], &[T], 1),
            Err(SessionFault::GroupOutOfRange { row: 0, group: 5 })
        );
        assert_eq!(check(&[], &[T; 9], 1), Err(SessionFault::ScratchTooSmall));
    }

    #[test]
    fn with_a_frame_per_session_instrument_rows_span_sessions_but_each_needs_three() {
        let mut z = [[0usize; 4]; 5];
        let [a, b, c, d, e] = &mut z;
        let mut run = |rows: &[(RowRole, usize)]| {
            check_sessions(
                rows.iter().copied(),
                |_| T,
                &SessionLayout {
                    n_groups: 1,
                    n_sessions: 3,
                    sessions_given: true,
                    instrument_frames: true,
                },
                SessionScratch {
                    group_rows: &mut *a,
                    group_first: &mut *b,
                    group_session: &mut *c,
                    session_rows: &mut *d,
                    session_first: &mut *e,
                },
            )
        };
        // The first session's frame is the base: two instrument rows are enough there.
        let good = [
            (I, 0),
            (I, 0),
            (C(0), 0),
            (C(0), 0),
            (I, 1),
            (I, 1),
            (I, 1),
            (I, 2),
            (I, 2),
            (I, 2),
        ];
        assert_eq!(run(&good), Ok(()));
        // Session 2 has two instrument rows and a contact: its frame is undetermined.
        let few = [(I, 0), (I, 0), (I, 0), (I, 2), (C(0), 2), (C(0), 2), (I, 2)];
        assert_eq!(
            run(&few),
            Err(SessionFault::FrameTooSmall {
                session: 2,
                rows: 2,
                first: 3
            })
        );
    }

    #[test]
    fn without_sessions_a_small_set_is_not_refused() {
        let mut z = [[0usize; 2]; 5];
        let [a, b, c, d, e] = &mut z;
        let r = check_sessions(
            [(I, 0)],
            |_| T,
            &SessionLayout {
                n_groups: 0,
                n_sessions: 1,
                sessions_given: false,
                instrument_frames: false,
            },
            SessionScratch {
                group_rows: a,
                group_first: b,
                group_session: c,
                session_rows: d,
                session_first: e,
            },
        );
        assert_eq!(r, Ok(()));
    }
}
