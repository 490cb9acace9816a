//! The keyboard: one table of bindings, used both to turn key presses into [`Action`]s
//! and to list the keys in the help overlay. Keys are taken before the panels are drawn,
//! so a focused slider never sees the arrows; while a text field has focus, keys type.

use egui::{Key, Modifiers};

use crate::app::action::Action;
use crate::app::settings::{Overlay, ViewMode};
use crate::app::state::AppState;

/// One key binding.
#[derive(Debug, Clone, Copy)]
pub struct Binding {
    /// Modifiers that must be held.
    pub modifiers: Modifiers,
    /// The key.
    pub key: Key,
    /// What it does.
    pub action: Action,
    /// The key as the help overlay writes it.
    pub keys: &'static str,
    /// What it does, in words.
    pub help: &'static str,
}

const fn bind(
    modifiers: Modifiers,
    key: Key,
    action: Action,
    keys: &'static str,
    help: &'static str,
) -> Binding {
    Binding {
        modifiers,
        key,
        action,
        keys,
        help,
    }
}

/// Every binding, most specific first (a binding with Shift is matched before the same key
/// without it).
pub const BINDINGS: &[Binding] = &[
    bind(
        Modifiers::COMMAND.plus(Modifiers::SHIFT),
        Key::Z,
        Action::Redo,
        "Ctrl+Shift+Z or Ctrl+Y",
        "labeling: redo",
    ),
    bind(
        Modifiers::COMMAND,
        Key::Z,
        Action::Undo,
        "Ctrl+Z",
        "labeling: undo",
    ),
    bind(
        Modifiers::COMMAND,
        Key::Y,
        Action::Redo,
        "Ctrl+Y",
        "labeling: redo",
    ),
    bind(
        Modifiers::NONE,
        Key::L,
        Action::ToggleLabeling,
        "L",
        "labeling mode on / off",
    ),
    bind(
        Modifiers::NONE,
        Key::OpenBracket,
        Action::StartInterval,
        "[",
        "labeling: start an interval at the cursor",
    ),
    bind(
        Modifiers::NONE,
        Key::CloseBracket,
        Action::EndInterval,
        "]",
        "labeling: end the interval at the cursor",
    ),
    bind(
        Modifiers::NONE,
        Key::E,
        Action::MoveNearestEdge,
        "E",
        "labeling: move the nearest interval edge to the cursor",
    ),
    bind(
        Modifiers::NONE,
        Key::T,
        Action::TagRange,
        "T",
        "labeling: tag the range ([ to cursor, or the selected failure run)",
    ),
    bind(
        Modifiers::NONE,
        Key::Delete,
        Action::DeleteSelectedBox,
        "Delete",
        "labeling: delete the selected box from this frame on",
    ),
    bind(
        Modifiers::NONE,
        Key::Space,
        Action::TogglePlay,
        "Space",
        "play / pause",
    ),
    bind(
        Modifiers::COMMAND,
        Key::ArrowLeft,
        Action::PreviousEvent,
        "Ctrl+Left",
        "previous anomaly event",
    ),
    bind(
        Modifiers::COMMAND,
        Key::ArrowRight,
        Action::NextEvent,
        "Ctrl+Right",
        "next anomaly event",
    ),
    bind(
        Modifiers::SHIFT,
        Key::ArrowLeft,
        Action::Step(-10),
        "Shift+Left",
        "back 10 frames",
    ),
    bind(
        Modifiers::SHIFT,
        Key::ArrowRight,
        Action::Step(10),
        "Shift+Right",
        "forward 10 frames",
    ),
    bind(
        Modifiers::NONE,
        Key::ArrowLeft,
        Action::Step(-1),
        "Left",
        "previous frame",
    ),
    bind(
        Modifiers::NONE,
        Key::ArrowRight,
        Action::Step(1),
        "Right",
        "next frame",
    ),
    bind(
        Modifiers::NONE,
        Key::Home,
        Action::First,
        "Home",
        "first frame",
    ),
    bind(Modifiers::NONE, Key::End, Action::Last, "End", "last frame"),
    bind(
        Modifiers::NONE,
        Key::PageUp,
        Action::StepScenario(-1),
        "PgUp",
        "previous scenario",
    ),
    bind(
        Modifiers::NONE,
        Key::PageDown,
        Action::StepScenario(1),
        "PgDn",
        "next scenario",
    ),
    bind(
        Modifiers::SHIFT,
        Key::F,
        Action::StepFailure(-1),
        "Shift+F",
        "previous failure case",
    ),
    bind(
        Modifiers::NONE,
        Key::F,
        Action::StepFailure(1),
        "F",
        "next failure case",
    ),
    bind(
        Modifiers::NONE,
        Key::Num1,
        Action::SetView(ViewMode::Frame),
        "1",
        "view: frame with overlays",
    ),
    bind(
        Modifiers::NONE,
        Key::Num2,
        Action::SetView(ViewMode::Prediction),
        "2",
        "view: predicted vs actual",
    ),
    bind(
        Modifiers::NONE,
        Key::Num3,
        Action::SetView(ViewMode::Flow),
        "3",
        "view: flow vs reconstruction",
    ),
    bind(
        Modifiers::NONE,
        Key::H,
        Action::ToggleOverlay(Overlay::Heatmap),
        "H",
        "heatmap overlay on / off",
    ),
    bind(
        Modifiers::NONE,
        Key::B,
        Action::ToggleOverlay(Overlay::Boxes),
        "B",
        "boxes on / off",
    ),
    bind(
        Modifiers::NONE,
        Key::M,
        Action::ToggleOverlay(Overlay::Mask),
        "M",
        "anomaly-mask contour on / off",
    ),
    bind(
        Modifiers::NONE,
        Key::C,
        Action::ToggleOverlay(Overlay::Caption),
        "C",
        "caption strip on / off",
    ),
    bind(
        Modifiers::NONE,
        Key::Escape,
        Action::SelectObject(None),
        "Esc",
        "deselect the object",
    ),
    bind(
        Modifiers::NONE,
        Key::F1,
        Action::ToggleHelp,
        "F1 or ?",
        "this help",
    ),
    bind(
        Modifiers::NONE,
        Key::Questionmark,
        Action::ToggleHelp,
        "?",
        "this help",
    ),
];

/// Other keys, handled by the panels (listed in the help overlay).
pub const OTHER_KEYS: &[(&str, &str)] = &[
    ("Ctrl+O", "open a scenario or data set"),
    ("Ctrl+S", "export the current view as PNG"),
    ("Ctrl+E", "export frames, GIF and scores.csv"),
    ("click / drag timeline", "seek"),
    ("wheel on timeline", "zoom (Shift+wheel or right-drag: pan)"),
    ("drag the threshold line", "move the threshold"),
    ("click a box", "inspect the object"),
    (
        "labeling: drag an interval edge",
        "move it (labels lane of the timeline)",
    ),
    ("labeling: drag on the frame", "draw a box"),
    (
        "labeling: drag a box / a corner",
        "move / resize it at this frame",
    ),
    ("drop a folder", "open it"),
];

/// Applies every bound key pressed this frame (unless a text field has focus).
pub fn apply_keys(ctx: &egui::Context, state: &mut AppState) {
    if ctx.egui_wants_keyboard_input() {
        return;
    }
    let actions: Vec<Action> = ctx.input_mut(|input| {
        BINDINGS
            .iter()
            .filter(|b| input.consume_key(b.modifiers, b.key))
            .map(|b| b.action)
            .collect()
    });
    for action in actions {
        state.apply(action);
    }
}
