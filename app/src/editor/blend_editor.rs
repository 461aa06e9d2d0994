//! The blend tree as the inspector edits it: operators as nodes (kind and parameter), groups as
//! leaves (which group), nested as the tree nests. A node can change kind (its operands stay;
//! a difference takes the first two), gain a group or an operator as an operand, be wrapped in
//! a new operator, or be removed from its parent. The widgets edit a copy; the caller applies the
//! new tree as one edit.

use eframe::egui;
use skeletrace_core::model::scene::Blend;

/// The operator kinds, in the order the inspector offers them.
const KINDS: [&str; 7] = [
    "sum",
    "max",
    "min",
    "difference",
    "Ricci",
    "smooth union",
    "smooth intersection",
];

/// A node's kind in [`KINDS`]; `None` for a group leaf.
fn kind_of(node: &Blend) -> Option<usize> {
    Some(match node {
        Blend::Group(_) => return None,
        Blend::Sum(_) => 0,
        Blend::Max(_) => 1,
        Blend::Min(_) => 2,
        Blend::Difference(..) => 3,
        Blend::Ricci { .. } => 4,
        Blend::SmoothUnion { .. } => 5,
        Blend::SmoothIntersection { .. } => 6,
    })
}

/// A node's Ricci exponent and blend width, with the values a new Ricci or smooth operator
/// starts from where the node has none.
fn parameters(node: &Blend) -> (f64, f64) {
    match node {
        Blend::Ricci { p, .. } => (*p, 0.2),
        Blend::SmoothUnion { width, .. } | Blend::SmoothIntersection { width, .. } => (2.0, *width),
        _ => (2.0, 0.2),
    }
}

/// The operands of an operator, in order (none for a leaf).
fn operands(node: Blend) -> Vec<Blend> {
    match node {
        Blend::Group(_) => Vec::new(),
        Blend::Difference(a, b) => vec![*a, *b],
        Blend::Sum(v) | Blend::Max(v) | Blend::Min(v) => v,
        Blend::Ricci { of, .. }
        | Blend::SmoothUnion { of, .. }
        | Blend::SmoothIntersection { of, .. } => of,
    }
}

/// The operator of kind `kind` over `of` (a difference takes the first two, padded with the
/// first group), keeping `p` and `width` for the parametrised kinds.
#[must_use]
pub fn operator(kind: usize, mut of: Vec<Blend>, p: f64, width: f64) -> Blend {
    match kind {
        1 => Blend::Max(of),
        2 => Blend::Min(of),
        3 => {
            of.resize(2, Blend::Group(0));
            let b = of.pop().unwrap_or(Blend::Group(0));
            let a = of.pop().unwrap_or(Blend::Group(0));
            Blend::Difference(Box::new(a), Box::new(b))
        }
        4 => Blend::Ricci { p, of },
        5 => Blend::SmoothUnion { width, of },
        6 => Blend::SmoothIntersection { width, of },
        _ => Blend::Sum(of),
    }
}

/// What the user asked of a node besides editing it in place.
enum Ask {
    /// Nothing.
    Keep,
    /// Take it out of its parent.
    Remove,
}

/// Edits the tree `root` over the groups named `groups`; whether it changed.
pub fn edit(ui: &mut egui::Ui, root: &mut Blend, groups: &[String]) -> bool {
    let before = root.clone();
    node(ui, root, groups, &mut vec![0], false);
    *root != before
}

/// One node at `path` (for widget ids); `removable` where its parent can do without it.
fn node(
    ui: &mut egui::Ui,
    this: &mut Blend,
    groups: &[String],
    path: &mut Vec<usize>,
    removable: bool,
) -> Ask {
    let mut ask = Ask::Keep;
    let id = ("blend node", path.clone());
    ui.horizontal_wrapped(|ui| match this {
        Blend::Group(g) => {
            let mut chosen = *g as usize;
            egui::ComboBox::from_id_salt(id.clone())
                .selected_text(groups.get(chosen).cloned().unwrap_or_default())
                .show_ui(ui, |ui| {
                    for (k, name) in groups.iter().enumerate() {
                        ui.selectable_value(&mut chosen, k, name);
                    }
                })
                .response
                .on_hover_text("the group this leaf blends");
            *g = chosen as u32;
            if ui
                .small_button("wrap")
                .on_hover_text("put this leaf under a new sum")
                .clicked()
            {
                *this = Blend::Sum(vec![this.clone()]);
            }
            if removable
                && ui
                    .small_button("remove")
                    .on_hover_text("take this leaf out of its operator")
                    .clicked()
            {
                ask = Ask::Remove;
            }
        }
        _ => {
            let current = kind_of(this).unwrap_or(0);
            let mut kind = current;
            egui::ComboBox::from_id_salt(id.clone())
                .selected_text(KINDS[kind])
                .show_ui(ui, |ui| {
                    for (k, name) in KINDS.iter().enumerate() {
                        ui.selectable_value(&mut kind, k, *name);
                    }
                })
                .response
                .on_hover_text("the operator: its operands stay (a difference takes two)");
            let (mut p, mut width) = parameters(this);
            match kind {
                4 => {
                    ui.add(egui::Slider::new(&mut p, 1.0..=32.0).text("p"))
                        .on_hover_text("the Ricci exponent: 1 is the sum, large p nears the max");
                }
                5 | 6 => {
                    ui.add(egui::Slider::new(&mut width, 0.01..=2.0).text("width"))
                        .on_hover_text("the blend width, in field units");
                }
                _ => {}
            }
            let parameters_changed = match this {
                Blend::Ricci { p: old, .. } => *old != p,
                Blend::SmoothUnion { width: old, .. }
                | Blend::SmoothIntersection { width: old, .. } => *old != width,
                _ => false,
            };
            if kind != current || parameters_changed {
                *this = operator(kind, operands(this.clone()), p, width);
            }
            let takes_more = !matches!(this, Blend::Difference(..));
            if takes_more
                && ui
                    .small_button("+ group")
                    .on_hover_text("add a group as an operand")
                    .clicked()
            {
                let of = operands(this.clone());
                let mut of = of;
                of.push(Blend::Group(0));
                *this = operator(kind_of(this).unwrap_or(0), of, p, width);
            }
            if takes_more
                && ui
                    .small_button("+ operator")
                    .on_hover_text("add a sum of the first group as an operand")
                    .clicked()
            {
                let mut of = operands(this.clone());
                of.push(Blend::Sum(vec![Blend::Group(0)]));
                *this = operator(kind_of(this).unwrap_or(0), of, p, width);
            }
            if removable
                && ui
                    .small_button("remove")
                    .on_hover_text("take this operator and its operands out")
                    .clicked()
            {
                ask = Ask::Remove;
            }
        }
    });
    // The operands, indented under their operator.
    let kind = kind_of(this);
    if let Some(kind) = kind {
        let (p, width) = parameters(this);
        let mut of = operands(this.clone());
        // A difference keeps both operands; the others keep at least one.
        let can_remove = kind != 3 && of.len() > 1;
        let mut removed = None;
        ui.indent(id.clone(), |ui| {
            for (k, child) in of.iter_mut().enumerate() {
                path.push(k);
                if let Ask::Remove = node(ui, child, groups, path, can_remove) {
                    removed = Some(k);
                }
                path.pop();
            }
        });
        if let Some(k) = removed {
            of.remove(k);
        }
        let rebuilt = operator(kind, of, p, width);
        if rebuilt != *this {
            *this = rebuilt;
        }
    }
    ask
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Changing an operator's kind keeps its operands (a difference takes two, padding with
    /// the first group) and its parameter where the new kind has one.
    #[test]
    fn a_new_kind_keeps_the_operands() {
        let of = vec![Blend::Group(2), Blend::Group(0), Blend::Group(1)];
        assert_eq!(operator(1, of.clone(), 3.0, 0.4), Blend::Max(of.clone()));
        assert_eq!(
            operator(3, of.clone(), 3.0, 0.4),
            Blend::Difference(Box::new(Blend::Group(2)), Box::new(Blend::Group(0)))
        );
        assert_eq!(
            operator(3, vec![Blend::Group(1)], 3.0, 0.4),
            Blend::Difference(Box::new(Blend::Group(1)), Box::new(Blend::Group(0)))
        );
        assert_eq!(
            operator(4, of.clone(), 3.0, 0.4),
            Blend::Ricci {
                p: 3.0,
                of: of.clone()
            }
        );
        assert_eq!(
            operator(6, of.clone(), 3.0, 0.4),
            Blend::SmoothIntersection { width: 0.4, of }
        );
        for kind in 0..KINDS.len() {
            let node = operator(kind, vec![Blend::Group(0), Blend::Group(1)], 2.0, 0.2);
            assert_eq!(kind_of(&node), Some(kind));
        }
    }
}
