//! The hotkeys: one table, [`HOTKEYS`], from which both the window's key dispatch
//! ([`action`]) and the help overlay ([`help_lines`]) are made, so the two cannot disagree.

use glam::DVec2;
use winit::keyboard::KeyCode;

use super::panel::Command;
use Action::{Do, NextEngine, Pull};
use Command as C;
use KeyCode as K;

/// Which way an arrow key pulls the key ball.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Arrow {
    /// ←: towards −x.
    Left = 0,
    /// →: towards +x.
    Right = 1,
    /// ↓: towards −y.
    Down = 2,
    /// ↑: towards +y.
    Up = 3,
}

impl Arrow {
    /// Every arrow, in the order of their index (the window's `arrows` array).
    pub const ALL: [Arrow; 4] = [Arrow::Left, Arrow::Right, Arrow::Down, Arrow::Up];

    /// The unit direction of the pull, field axes (x right, y up).
    pub fn direction(self) -> DVec2 {
        match self {
            Arrow::Left => DVec2::NEG_X,
            Arrow::Right => DVec2::X,
            Arrow::Down => DVec2::NEG_Y,
            Arrow::Up => DVec2::Y,
        }
    }
}

/// What a key does.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Action {
    /// Pulls the key ball while the key is held; arrows held together combine into one pull of
    /// the same strength (a diagonal pulls as hard as one arrow).
    Pull(Arrow),
    /// Carries out a command when the key goes down.
    Do(Command),
    /// Switches to the engine after the one that runs (E): which one that is depends on the
    /// running engine, so it cannot be a fixed [`Command`].
    NextEngine,
}

/// One line of the help: what the keys do, and the keys, each with the name the help shows.
pub struct Hotkey {
    /// What the keys do, as the help says it.
    pub what: &'static str,
    /// Each key: its code, the name the help shows for it, and what it does. A key code appears
    /// once in all of [`HOTKEYS`].
    pub keys: &'static [(KeyCode, &'static str, Action)],
}

/// Every hotkey of the window, in the order the help lists them.
pub const HOTKEYS: &[Hotkey] = &[
    Hotkey {
        what: "pull the key ball (hold; keys combine, a diagonal pulls as hard as one arrow)",
        keys: &[
            (K::ArrowLeft, "←", Pull(Arrow::Left)),
            (K::ArrowUp, "↑", Pull(Arrow::Up)),
            (K::ArrowRight, "→", Pull(Arrow::Right)),
            (K::ArrowDown, "↓", Pull(Arrow::Down)),
        ],
    },
    Hotkey {
        what: "add a ball",
        keys: &[
            (K::KeyA, "A", Do(C::AddBall)),
            (K::Equal, "=", Do(C::AddBall)),
            (K::NumpadAdd, "keypad +", Do(C::AddBall)),
        ],
    },
    Hotkey {
        what: "remove the last ball added",
        keys: &[
            (K::Backspace, "Backspace", Do(C::RemoveLast)),
            (K::Delete, "Delete", Do(C::RemoveLast)),
            (K::Minus, "-", Do(C::RemoveLast)),
            (K::NumpadSubtract, "keypad -", Do(C::RemoveLast)),
        ],
    },
    Hotkey {
        what: "pause / resume",
        keys: &[(K::Space, "Space", Do(C::TogglePause)), (K::KeyP, "P", Do(C::TogglePause))],
    },
    Hotkey { what: "single step (while paused)", keys: &[(K::KeyS, "S", Do(C::Step)), (K::Period, ".", Do(C::Step))] },
    Hotkey { what: "reset the scene", keys: &[(K::KeyR, "R", Do(C::Reset))] },
    Hotkey {
        what: "gravity / drag / attraction / collisions on or off",
        keys: &[
            (K::KeyG, "G", Do(C::ToggleGravity)),
            (K::KeyD, "D", Do(C::ToggleDrag)),
            (K::KeyN, "N", Do(C::ToggleAttraction)),
            (K::KeyC, "C", Do(C::ToggleCollisions)),
        ],
    },
    Hotkey {
        what: "switch scene (the panel's list)",
        keys: &[
            (K::Digit1, "1", Do(C::Scene(0))),
            (K::Digit2, "2", Do(C::Scene(1))),
            (K::Digit3, "3", Do(C::Scene(2))),
            (K::Digit4, "4", Do(C::Scene(3))),
            (K::Digit5, "5", Do(C::Scene(4))),
            (K::Digit6, "6", Do(C::Scene(5))),
            (K::Digit7, "7", Do(C::Scene(6))),
            (K::Digit8, "8", Do(C::Scene(7))),
        ],
    },
    Hotkey {
        what: "switch engine (threaded / lockstep / exact), keeping the balls",
        keys: &[(K::KeyE, "E", NextEngine)],
    },
    Hotkey {
        what: "velocity vectors / centre of mass / traces",
        keys: &[
            (K::KeyV, "V", Do(C::ToggleVectors)),
            (K::KeyM, "M", Do(C::ToggleCentreOfMass)),
            (K::KeyT, "T", Do(C::ToggleTraces)),
        ],
    },
    Hotkey { what: "show / hide the panel", keys: &[(K::Tab, "Tab", Do(C::TogglePanel))] },
    Hotkey { what: "this help", keys: &[(K::KeyH, "H", Do(C::ToggleHelp)), (K::F1, "F1", Do(C::ToggleHelp))] },
    Hotkey { what: "quit", keys: &[(K::Escape, "Esc", Do(C::Quit)), (K::KeyQ, "Q", Do(C::Quit))] },
];

/// What `code` does, if it is a hotkey.
pub fn action(code: KeyCode) -> Option<Action> {
    HOTKEYS.iter().flat_map(|h| h.keys).find(|(k, _, _)| *k == code).map(|&(_, _, a)| a)
}

/// The keys of one line as the help shows them: a run of consecutive digits as "1 – 8", the
/// arrows side by side (one gesture), other keys separated by " / ".
pub fn label(hotkey: &Hotkey) -> String {
    let names: Vec<&str> = hotkey.keys.iter().map(|(_, n, _)| *n).collect();
    let digits: Option<Vec<u32>> = names.iter().map(|n| n.parse().ok()).collect();
    if let Some(d) = digits
        && d.len() >= 3
        && d.windows(2).all(|w| w[1] == w[0] + 1)
    {
        return format!("{} – {}", d[0], d[d.len() - 1]);
    }
    let arrows = hotkey.keys.iter().all(|(_, _, a)| matches!(a, Pull(_)));
    names.join(if arrows { " " } else { " / " })
}

/// The help's key lines, `(keys, what they do)`, in the table's order.
pub fn help_lines() -> impl Iterator<Item = (String, &'static str)> {
    HOTKEYS.iter().map(|h| (label(h), h.what))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each key is bound once: a second binding would be shadowed by the first in [`action`]
    /// and listed twice in the help. Seen to fail by adding `(K::KeyA, "A", Do(C::Reset))` to
    /// the reset line.
    #[test]
    fn every_hotkey_is_listed_once() {
        let codes: Vec<KeyCode> = HOTKEYS.iter().flat_map(|h| h.keys).map(|(k, _, _)| *k).collect();
        for (i, k) in codes.iter().enumerate() {
            assert!(!codes[i + 1..].contains(k), "{k:?} is bound twice");
        }
        let names: Vec<&str> = HOTKEYS.iter().flat_map(|h| h.keys).map(|(_, n, _)| *n).collect();
        for (i, n) in names.iter().enumerate() {
            assert!(!n.is_empty() && !names[i + 1..].contains(n), "the help names two keys {n:?}");
        }
    }

    /// The bindings, written out: the keys the window has always had, including the ones the
    /// old help left out (`=`, `-`, `.`, the keypad's + and -), each on the help line that says
    /// what it does. Seen to fail by dropping `(K::Period, ...)` from the step line.
    #[test]
    fn the_help_lists_every_binding_on_its_line() {
        let expected: &[(KeyCode, Action, &str)] = &[
            (K::ArrowLeft, Pull(Arrow::Left), "← ↑ → ↓"),
            (K::ArrowRight, Pull(Arrow::Right), "← ↑ → ↓"),
            (K::ArrowUp, Pull(Arrow::Up), "← ↑ → ↓"),
            (K::ArrowDown, Pull(Arrow::Down), "← ↑ → ↓"),
            (K::KeyA, Do(C::AddBall), "A / = / keypad +"),
            (K::Equal, Do(C::AddBall), "A / = / keypad +"),
            (K::NumpadAdd, Do(C::AddBall), "A / = / keypad +"),
            (K::Backspace, Do(C::RemoveLast), "Backspace / Delete / - / keypad -"),
            (K::Delete, Do(C::RemoveLast), "Backspace / Delete / - / keypad -"),
            (K::Minus, Do(C::RemoveLast), "Backspace / Delete / - / keypad -"),
            (K::NumpadSubtract, Do(C::RemoveLast), "Backspace / Delete / - / keypad -"),
            (K::Space, Do(C::TogglePause), "Space / P"),
            (K::KeyP, Do(C::TogglePause), "Space / P"),
            (K::KeyS, Do(C::Step), "S / ."),
            (K::Period, Do(C::Step), "S / ."),
            (K::KeyR, Do(C::Reset), "R"),
            (K::KeyG, Do(C::ToggleGravity), "G / D / N / C"),
            (K::KeyD, Do(C::ToggleDrag), "G / D / N / C"),
            (K::KeyN, Do(C::ToggleAttraction), "G / D / N / C"),
            (K::KeyC, Do(C::ToggleCollisions), "G / D / N / C"),
            (K::Digit1, Do(C::Scene(0)), "1 – 8"),
            (K::Digit5, Do(C::Scene(4)), "1 – 8"),
            (K::Digit8, Do(C::Scene(7)), "1 – 8"),
            (K::KeyE, NextEngine, "E"),
            (K::KeyV, Do(C::ToggleVectors), "V / M / T"),
            (K::KeyM, Do(C::ToggleCentreOfMass), "V / M / T"),
            (K::KeyT, Do(C::ToggleTraces), "V / M / T"),
            (K::Tab, Do(C::TogglePanel), "Tab"),
            (K::KeyH, Do(C::ToggleHelp), "H / F1"),
            (K::F1, Do(C::ToggleHelp), "H / F1"),
            (K::Escape, Do(C::Quit), "Esc / Q"),
            (K::KeyQ, Do(C::Quit), "Esc / Q"),
        ];
        let lines: Vec<(String, &str)> = help_lines().collect();
        for (code, act, line) in expected {
            assert_eq!(action(*code), Some(*act), "{code:?}");
            let holder = HOTKEYS.iter().position(|h| h.keys.iter().any(|(k, _, _)| k == code)).unwrap();
            assert_eq!(lines[holder].0, *line, "{code:?} is listed on the wrong line");
        }
        let bound = HOTKEYS.iter().map(|h| h.keys.len()).sum::<usize>();
        // The eight digits are three of the expected rows above.
        assert_eq!(bound, expected.len() + 5, "a binding is missing from the expected list");
        assert_eq!(action(K::KeyZ), None);
    }

    #[test]
    fn digits_only_in_a_run_are_a_range() {
        let two = Hotkey { what: "", keys: &[(K::Digit1, "1", Do(C::Scene(0))), (K::Digit2, "2", Do(C::Scene(1)))] };
        assert_eq!(label(&two), "1 / 2");
        let gap = Hotkey {
            what: "",
            keys: &[
                (K::Digit1, "1", Do(C::Scene(0))),
                (K::Digit2, "2", Do(C::Scene(1))),
                (K::Digit4, "4", Do(C::Scene(3))),
            ],
        };
        assert_eq!(label(&gap), "1 / 2 / 4");
    }
}
