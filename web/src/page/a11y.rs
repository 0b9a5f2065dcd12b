//! The panels for assistive technology: egui's AccessKit tree as the element mirrors it in
//! its shadow DOM (invisible nodes with ARIA roles, names, states and values, placed over the
//! widgets they stand for), and what assistive technology asks back (click, focus, set a
//! value) as egui action requests. Platform-free, so it is tested natively.
//!
//! egui rebuilds its whole tree every frame; [`Mirror::update`] sends the element only the
//! nodes that changed since the last frame and the ones that went away, as JSON:
//!
//! ```json
//! { "full": false, "root": "1", "nodes": [ { "id": "7", "role": "button", "name": "Play", "parent": "3",
//!   "children": [], "x": 12, "y": 40, "w": 48, "h": 20, "focusable": true, … } ], "removed": ["9"] }
//! ```

use std::collections::HashMap;
use std::hash::{Hash, Hasher};

use egui::accesskit::{Action, ActionData, ActionRequest, Node, NodeId, Role, Toggled, TreeId, TreeUpdate};
use serde_json::{Map, Value, json};

/// How a node is shown in the DOM.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// A container of other nodes (no box of its own).
    Group,
    /// A control the keyboard reaches (a button-like element, a range, a text field).
    Control,
    /// Text to read.
    Text,
    /// Left out (scroll bars, the root window): its children go to its parent.
    Skip,
}

/// The ARIA role of an AccessKit role (`""`: no role, a generic element) and how it is shown.
pub fn aria_role(role: Role) -> (&'static str, Kind) {
    use Kind::{Control, Group, Skip, Text};
    match role {
        Role::Button | Role::DefaultButton | Role::DisclosureTriangle => ("button", Control),
        Role::CheckBox => ("checkbox", Control),
        Role::Switch => ("switch", Control),
        Role::RadioButton => ("radio", Control),
        Role::ComboBox | Role::EditableComboBox => ("combobox", Control),
        Role::Slider => ("slider", Control),
        Role::SpinButton => ("spinbutton", Control),
        Role::TextInput
        | Role::MultilineTextInput
        | Role::SearchInput
        | Role::EmailInput
        | Role::NumberInput
        | Role::PasswordInput
        | Role::PhoneNumberInput
        | Role::UrlInput => ("textbox", Control),
        Role::Link => ("link", Control),
        Role::MenuItem => ("menuitem", Control),
        Role::MenuItemCheckBox => ("menuitemcheckbox", Control),
        Role::MenuItemRadio => ("menuitemradio", Control),
        Role::ListBoxOption => ("option", Control),
        Role::Tab => ("tab", Control),
        Role::Label | Role::Paragraph | Role::Caption => ("", Text),
        Role::Heading => ("heading", Text),
        Role::ProgressIndicator | Role::Meter => ("progressbar", Text),
        Role::Image => ("img", Text),
        Role::Group => ("group", Group),
        Role::RadioGroup => ("radiogroup", Group),
        Role::ListBox => ("listbox", Group),
        Role::List => ("list", Group),
        Role::ListItem => ("listitem", Group),
        Role::Menu => ("menu", Group),
        Role::MenuBar => ("menubar", Group),
        Role::Dialog | Role::AlertDialog => ("dialog", Group),
        Role::Tooltip => ("tooltip", Group),
        Role::Toolbar => ("toolbar", Group),
        Role::TabList => ("tablist", Group),
        Role::Alert => ("alert", Group),
        Role::Status => ("status", Group),
        Role::Region => ("region", Group),
        // The panel's resize handle too: the keyboard has no use for it.
        Role::ScrollBar | Role::Window | Role::Splitter => ("", Skip),
        _ => ("", Group),
    }
}

/// What the element needs of one node (compared frame to frame).
struct Entry {
    json: Value,
    hash: u64,
}

/// The mirrored tree: what the element was last sent.
#[derive(Debug, Default)]
pub struct Mirror {
    sent: HashMap<NodeId, u64>,
    /// The ARIA role and name of every control of the last tree, in tree order (for tests:
    /// what the page's accessibility tree must list).
    controls: Vec<(&'static str, String)>,
    root: Option<NodeId>,
    focus: Option<NodeId>,
}

/// The accessible name of `node`: its label, else the labels (or text) of the nodes that
/// label it, else its placeholder.
fn name_of(node: &Node, nodes: &HashMap<NodeId, &Node>) -> String {
    if let Some(label) = node.label().filter(|l| !l.is_empty()) {
        return label.to_owned();
    }
    let from: Vec<&str> = node
        .labelled_by()
        .iter()
        .filter_map(|id| nodes.get(id))
        .filter_map(|n| n.label().or(n.value()))
        .filter(|s| !s.is_empty())
        .collect();
    if !from.is_empty() {
        return from.join(" ");
    }
    node.placeholder().unwrap_or_default().to_owned()
}

/// A number as the element gets it (`null` when not finite). Not rounded: a range's step must
/// stay exact (1/30 s rounded to 0.0333 put 2 s at 1.998).
fn number(v: f64) -> Value {
    if v.is_finite() { json!(v) } else { Value::Null }
}

/// The JSON of one node; `parent` is the mirrored node it goes under (skipped nodes' children
/// go to their nearest mirrored ancestor).
fn entry(
    controls: &mut Vec<(&'static str, String)>,
    id: NodeId,
    node: &Node,
    parent: Option<NodeId>,
    context: &str,
    children: &[NodeId],
    nodes: &HashMap<NodeId, &Node>,
) -> Entry {
    let (role, kind) = aria_role(node.role());
    // egui's popups list buttons: inside a list box they are its options, inside a menu its items.
    let role = match (role, context) {
        ("button", "listbox") => "option",
        ("button", "menu" | "menubar") => "menuitem",
        // A select-only combo box is a button that opens a list box (ARIA's combobox needs
        // states egui does not track).
        ("combobox", _) => "button",
        // A named container is a group (a name on an element without a role is not allowed).
        ("", _) if kind == Kind::Group && node.label().is_some_and(|l| !l.is_empty()) => "group",
        (role, _) => role,
    };
    let mut o = Map::new();
    o.insert("id".into(), json!(id.0.to_string()));
    o.insert("role".into(), json!(role));
    o.insert(
        "kind".into(),
        json!(match kind {
            Kind::Group => "group",
            Kind::Control => "control",
            Kind::Text => "text",
            Kind::Skip => "skip",
        }),
    );
    o.insert("parent".into(), json!(parent.map(|p| p.0.to_string())));
    o.insert("children".into(), Value::Array(children.iter().map(|c| json!(c.0.to_string())).collect()));
    let name = name_of(node, nodes);
    if kind == Kind::Control {
        controls.push((role, name.clone()));
    }
    if !name.is_empty() {
        o.insert("name".into(), json!(name));
    }
    if kind == Kind::Text {
        // A label's text is its value in AccessKit.
        let text = node.value().or(node.label()).unwrap_or_default();
        o.insert("text".into(), json!(text));
    } else if let Some(value) = node.value() {
        o.insert("value".into(), json!(value));
    }
    if let Some(v) = node.numeric_value() {
        o.insert("now".into(), number(v));
    }
    if let Some(v) = node.min_numeric_value() {
        o.insert("min".into(), number(v));
    }
    if let Some(v) = node.max_numeric_value() {
        o.insert("max".into(), number(v));
    }
    if let Some(v) = node.numeric_value_step() {
        o.insert("step".into(), number(v));
    }
    // A popup (a combo box's list, a menu, a dialog): egui names none of them (the panel's own
    // list boxes are named, e.g. "Clips"); the element names it after the control that opened it.
    if matches!(role, "listbox" | "menu" | "dialog") && name.is_empty() {
        o.insert("popup".into(), json!(true));
    }
    if node.role() == Role::ComboBox || node.role() == Role::EditableComboBox {
        o.insert("haspopup".into(), json!("listbox"));
    }
    if role == "option" {
        o.insert("selected".into(), json!(node.toggled() == Some(Toggled::True) || node.is_selected() == Some(true)));
    }
    if let Some(toggled) = node.toggled().filter(|_| role != "option") {
        o.insert(
            "checked".into(),
            json!(match toggled {
                Toggled::True => "true",
                Toggled::False => "false",
                Toggled::Mixed => "mixed",
            }),
        );
    }
    if let Some(expanded) = node.is_expanded() {
        o.insert("expanded".into(), json!(expanded));
    }
    if let Some(selected) = node.is_selected().filter(|_| role != "option") {
        o.insert("selected".into(), json!(selected));
    }
    if node.is_disabled() {
        o.insert("disabled".into(), json!(true));
    }
    if let Some(description) = node.description() {
        o.insert("description".into(), json!(description));
    }
    if let Some(placeholder) = node.placeholder() {
        o.insert("placeholder".into(), json!(placeholder));
    }
    if let Some(b) = node.bounds() {
        // egui's root scales points to pixels; every other node is in points (CSS pixels).
        o.insert("x".into(), json!((b.x0 * 10.0).round() / 10.0));
        o.insert("y".into(), json!((b.y0 * 10.0).round() / 10.0));
        o.insert("w".into(), json!(((b.x1 - b.x0) * 10.0).round() / 10.0));
        o.insert("h".into(), json!(((b.y1 - b.y0) * 10.0).round() / 10.0));
    }
    if node.supports_action(Action::Focus) {
        o.insert("focusable".into(), json!(true));
    }
    let mut actions = Vec::new();
    for (action, name) in [
        (Action::Click, "click"),
        (Action::SetValue, "setValue"),
        (Action::Increment, "increment"),
        (Action::Decrement, "decrement"),
    ] {
        if node.supports_action(action) {
            actions.push(name);
        }
    }
    if !actions.is_empty() {
        o.insert("actions".into(), json!(actions));
    }
    let json = Value::Object(o);
    let mut hasher = std::collections::hash_map::DefaultHasher::new();
    json.to_string().hash(&mut hasher);
    Entry { json, hash: hasher.finish() }
}

impl Mirror {
    /// Forgets what was sent (the element lost its mirror, e.g. a new context): the next
    /// update sends every node.
    pub fn reset(&mut self) {
        *self = Mirror::default();
    }

    /// The ARIA role and name of every control of the last tree, as JSON `[[role, name], …]`.
    pub fn controls_json(&self) -> String {
        serde_json::to_string(&self.controls).unwrap_or_default()
    }

    /// What changed since the last update, as the JSON the element applies (`None`: nothing).
    pub fn update(&mut self, update: &TreeUpdate) -> Option<String> {
        let nodes: HashMap<NodeId, &Node> = update.nodes.iter().map(|(id, n)| (*id, n)).collect();
        // The first update after a reset is the whole tree: the element drops what it holds besides.
        let full = self.root.is_none();
        let root = update.tree.as_ref().map(|t| t.root).or(self.root)?;
        let mut changed = Vec::new();
        let mut controls = Vec::with_capacity(self.controls.len());
        // The mirrored nodes of this tree and what they were sent as; every node visited.
        let mut sent: HashMap<NodeId, u64> = HashMap::with_capacity(nodes.len());
        let mut visited: std::collections::HashSet<NodeId> = std::collections::HashSet::with_capacity(nodes.len());
        // Depth first from the root, in the order egui laid the widgets out (the reading and
        // tab order); a node reached twice (a malformed tree) is taken once.
        let mut stack: Vec<(NodeId, Option<NodeId>, &'static str)> = vec![(root, None, "")];
        while let Some((id, parent, context)) = stack.pop() {
            if !visited.insert(id) {
                continue;
            }
            let Some(node) = nodes.get(&id) else { continue };
            let (role, kind) = aria_role(node.role());
            // The nearest ancestor's role that gives its children theirs (list box, menu).
            let child_context = if kind == Kind::Group && !role.is_empty() { role } else { context };
            // Children of a skipped node go to its parent; controls hold no other nodes (a
            // control inside a control is not allowed): theirs follow them as siblings. The
            // root is always mirrored (the element's container).
            let holds_children = id == root || matches!(kind, Kind::Group | Kind::Text);
            let children: Vec<NodeId> =
                node.children().iter().copied().filter(|c| nodes.contains_key(c) && !visited.contains(c)).collect();
            if id == root || kind != Kind::Skip {
                let listed = if holds_children { expand_skipped(&children, &nodes) } else { Vec::new() };
                let e = entry(&mut controls, id, node, parent, context, &listed, &nodes);
                if self.sent.get(&id) != Some(&e.hash) {
                    changed.push(e.json);
                }
                sent.insert(id, e.hash);
            }
            let child_parent = if holds_children { Some(id) } else { parent };
            for child in children.iter().rev() {
                stack.push((*child, child_parent, child_context));
            }
        }
        let removed: Vec<Value> =
            self.sent.keys().filter(|id| !sent.contains_key(id)).map(|id| json!(id.0.to_string())).collect();
        let focus = Some(update.focus);
        let focus_moved = focus != self.focus;
        let root_moved = Some(root) != self.root;
        self.sent = sent;
        self.controls = controls;
        self.focus = focus;
        self.root = Some(root);
        if changed.is_empty() && removed.is_empty() && !focus_moved && !root_moved {
            return None;
        }
        // The nodes go parents first: the element creates them in this order.
        Some(
            json!({
                "full": full,
                "root": root.0.to_string(),
                "focus": update.focus.0.to_string(),
                "nodes": changed,
                "removed": removed,
            })
            .to_string(),
        )
    }
}

/// `children` with every skipped node replaced by its own children (recursively).
fn expand_skipped(children: &[NodeId], nodes: &HashMap<NodeId, &Node>) -> Vec<NodeId> {
    let mut out = Vec::with_capacity(children.len());
    let mut stack: Vec<NodeId> = children.iter().rev().copied().collect();
    let mut guard = 0usize;
    while let Some(id) = stack.pop() {
        guard += 1;
        if guard > nodes.len() + children.len() {
            break;
        }
        let Some(node) = nodes.get(&id) else { continue };
        let (_, kind) = aria_role(node.role());
        if kind == Kind::Skip {
            stack.extend(node.children().iter().rev().copied());
        } else {
            out.push(id);
            if kind == Kind::Control {
                // A control's own children are listed after it (see `update`).
                stack.extend(node.children().iter().rev().copied());
            }
        }
    }
    out
}

/// An action request from the element: `action` is `click`, `focus`, `setValue`,
/// `increment`, `decrement` or `scrollIntoView`; `number`/`text` the value for `setValue`.
/// `None` for an unknown action or node id.
pub fn action_request(node: &str, action: &str, number: Option<f64>, text: Option<String>) -> Option<ActionRequest> {
    let target_node = NodeId(node.parse().ok()?);
    let action = match action {
        "click" => Action::Click,
        "focus" => Action::Focus,
        "setValue" => Action::SetValue,
        "increment" => Action::Increment,
        "decrement" => Action::Decrement,
        "scrollIntoView" => Action::ScrollIntoView,
        _ => return None,
    };
    let data = match (action, number.filter(|n| n.is_finite()), text) {
        (Action::SetValue, Some(n), _) => Some(ActionData::NumericValue(n)),
        (Action::SetValue, None, Some(t)) => Some(ActionData::Value(t.into_boxed_str())),
        (Action::SetValue, None, None) => return None,
        _ => None,
    };
    Some(ActionRequest { action, target_tree: TreeId::ROOT, target_node, data })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One pass of `ui` through egui (its texture changes dropped: nothing draws here).
    fn run(ctx: &egui::Context, events: Vec<egui::Event>, ui: impl FnMut(&mut egui::Ui)) -> egui::FullOutput {
        let mut out = ctx.run_ui(egui::RawInput { events, ..Default::default() }, ui);
        out.textures_delta.clear();
        out
    }

    fn parse(s: &str) -> Value {
        serde_json::from_str(s).expect("valid JSON")
    }

    /// One frame of a small panel through egui, with AccessKit on.
    fn frame(ctx: &egui::Context, speed: &mut f32, on: &mut bool) -> TreeUpdate {
        let out = run(ctx, Vec::new(), |ui| {
            ui.label("Kloub");
            let _ = ui.button("Play");
            ui.add(egui::Slider::new(speed, -3.0..=3.0).text("speed"));
            ui.checkbox(on, "Skeleton");
        });
        out.platform_output.accesskit_update.expect("AccessKit is on")
    }

    fn nodes(v: &Value) -> Vec<&Value> {
        v["nodes"].as_array().expect("nodes").iter().collect()
    }

    fn by_name<'a>(v: &'a Value, name: &str) -> &'a Value {
        nodes(v).into_iter().find(|n| n["name"] == name).unwrap_or_else(|| panic!("no node named {name}: {v}"))
    }

    #[test]
    fn the_first_update_mirrors_every_widget_with_its_role_name_and_value() {
        let ctx = egui::Context::default();
        ctx.enable_accesskit();
        let (mut speed, mut on) = (1.5, false);
        let _ = frame(&ctx, &mut speed, &mut on);
        let update = frame(&ctx, &mut speed, &mut on);
        let mut mirror = Mirror::default();
        let v = parse(&mirror.update(&update).expect("a first update"));
        let play = by_name(&v, "Play");
        assert_eq!(play["role"], "button");
        assert_eq!(play["kind"], "control");
        assert_eq!(play["focusable"], true);
        assert!(play["w"].as_f64().is_some_and(|w| w > 10.0), "{play}");
        assert!(play["actions"].as_array().is_some_and(|a| a.contains(&json!("click"))));
        let slider = by_name(&v, "speed");
        assert_eq!(slider["role"], "slider");
        assert_eq!(slider["now"], 1.5);
        assert_eq!(slider["min"], -3.0);
        assert_eq!(slider["max"], 3.0);
        let check = by_name(&v, "Skeleton");
        assert_eq!(check["role"], "checkbox");
        assert_eq!(check["checked"], "false");
        assert!(nodes(&v).iter().any(|n| n["kind"] == "text" && n["text"] == "Kloub"), "{v}");
        // Parents come before their children, and every child names a parent that was sent.
        let ids: Vec<&str> = nodes(&v).iter().filter_map(|n| n["id"].as_str()).collect();
        for (i, n) in nodes(&v).iter().enumerate() {
            if let Some(p) = n["parent"].as_str() {
                let at = ids.iter().position(|id| *id == p).expect("the parent was sent");
                assert!(at < i, "parent after child");
            }
        }
    }

    #[test]
    fn later_updates_send_only_what_changed_and_what_went_away() {
        let ctx = egui::Context::default();
        ctx.enable_accesskit();
        let (mut speed, mut on) = (1.0, false);
        let _ = frame(&ctx, &mut speed, &mut on);
        let mut mirror = Mirror::default();
        assert!(mirror.update(&frame(&ctx, &mut speed, &mut on)).is_some());
        assert_eq!(mirror.update(&frame(&ctx, &mut speed, &mut on)), None, "nothing changed");
        on = true;
        let v = parse(&mirror.update(&frame(&ctx, &mut speed, &mut on)).expect("the checkbox changed"));
        assert_eq!(nodes(&v).len(), 1, "{v}");
        assert_eq!(nodes(&v)[0]["checked"], "true");
        // A frame without the button: it is removed.
        let out = run(&ctx, Vec::new(), |ui| {
            ui.label("Kloub");
        });
        let v = parse(&mirror.update(&out.platform_output.accesskit_update.expect("on")).expect("removed nodes"));
        assert!(!v["removed"].as_array().expect("removed").is_empty());
    }

    #[test]
    fn actions_from_the_element_become_egui_requests_and_change_the_widgets() {
        let ctx = egui::Context::default();
        ctx.enable_accesskit();
        let (mut speed, mut on) = (1.0, false);
        let _ = frame(&ctx, &mut speed, &mut on);
        let update = frame(&ctx, &mut speed, &mut on);
        let mut mirror = Mirror::default();
        let v = parse(&mirror.update(&update).expect("first"));
        let slider = by_name(&v, "speed")["id"].as_str().expect("id").to_owned();
        let check = by_name(&v, "Skeleton")["id"].as_str().expect("id").to_owned();
        let events = vec![
            egui::Event::AccessKitActionRequest(action_request(&slider, "setValue", Some(2.0), None).expect("set")),
            egui::Event::AccessKitActionRequest(action_request(&check, "click", None, None).expect("click")),
        ];
        let _ = run(&ctx, events, |ui| {
            ui.label("Kloub");
            let _ = ui.button("Play");
            ui.add(egui::Slider::new(&mut speed, -3.0..=3.0).text("speed"));
            ui.checkbox(&mut on, "Skeleton");
        });
        assert_eq!(speed, 2.0);
        assert!(on);
        // Unknown actions, ids and values without data are refused, not guessed.
        assert!(action_request("x", "click", None, None).is_none());
        assert!(action_request("5", "dance", None, None).is_none());
        assert!(action_request("5", "setValue", Some(f64::NAN), None).is_none());
        assert!(action_request("5", "setValue", None, Some("Fox".into())).is_some());
    }

    #[test]
    fn scroll_bars_and_the_window_are_left_out_and_their_children_kept() {
        assert_eq!(aria_role(Role::ScrollBar).1, Kind::Skip);
        assert_eq!(aria_role(Role::Window).1, Kind::Skip);
        let ctx = egui::Context::default();
        ctx.enable_accesskit();
        let run = |ctx: &egui::Context| {
            run(ctx, Vec::new(), |ui| {
                egui::ScrollArea::vertical().max_height(20.0).show(ui, |ui| {
                    for i in 0..20 {
                        let _ = ui.button(format!("Clip {i}"));
                    }
                });
            })
        };
        let _ = run(&ctx);
        let out = run(&ctx);
        let mut mirror = Mirror::default();
        let v = parse(&mirror.update(&out.platform_output.accesskit_update.expect("on")).expect("first"));
        assert!(nodes(&v).iter().all(|n| n["kind"] != "skip" || n["id"] == v["root"]));
        let buttons = nodes(&v).iter().filter(|n| n["role"] == "button").count();
        assert_eq!(buttons, 20, "every button of the scrolled list, visible or not");
    }
}
