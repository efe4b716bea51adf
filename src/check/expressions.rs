//! Input expressions: literals, references, inline nodes, and the typed and constant forms
//! arguments take.

use super::*;

impl Checker {
    /// Lowers one input expression. `None` means it failed (and a diagnostic was recorded, here
    /// or for the node it refers to).
    pub(super) fn expression(&mut self, value: &Value, origin: &Origin) -> Option<NodeId> {
        let here = Origin {
            node: origin.node.clone(),
            span: value.span,
        };
        match &value.kind {
            ValueKind::Number(v) => {
                if v.is_nan() {
                    self.error(
                        Diagnostic::new(Class::BadParameter, "NaN is not allowed as a literal")
                            .in_node(&*origin.node)
                            .at(value.span)
                            .label("NaN")
                            .help("a NaN literal would make every result NaN"),
                    );
                    return None;
                }
                Some(self.builder.add(Op::ConstScalar(*v), Args::new(), &here))
            }
            ValueKind::Str(name) => self.reference(name, value.span, origin),
            ValueKind::Tuple { name: None, items } => {
                if items.len() != 3 {
                    self.error(
                        Diagnostic::new(
                            Class::Type,
                            format!(
                                "a vec3 literal has 3 components, this one has {}",
                                items.len()
                            ),
                        )
                        .in_node(&*origin.node)
                        .at(value.span)
                        .label("expected (x, y, z)"),
                    );
                    return None;
                }
                let mut components = Vec::with_capacity(3);
                for item in items {
                    components.push(self.typed_input(
                        item,
                        InputType::Scalar,
                        &"a vec3 component",
                        origin,
                    ));
                }
                let components: Option<Args> = components.into_iter().collect();
                Some(self.builder.add(Op::Combine, components?, &here))
            }
            ValueKind::Ident(kind_name) => {
                self.node(kind_name, value.span, &[], &[], value, origin)
            }
            ValueKind::Tuple {
                name: Some(kind_name),
                items,
            } => self.node(&kind_name.value, kind_name.span, items, &[], value, origin),
            ValueKind::Struct {
                name: Some(kind_name),
                fields,
            } => self.node(&kind_name.value, kind_name.span, &[], fields, value, origin),
            other => {
                self.error(
                    Diagnostic::new(Class::Type, format!("expected an input (a \"reference\", a number, a vec3 (x, y, z) or a node), found {}", other.describe()))
                        .in_node(&*origin.node)
                        .at(value.span)
                        .label("not an input"),
                );
                None
            }
        }
    }

    /// Lowers an input and checks its type (a vec3 where a scalar is expected is an error; a
    /// scalar where a vec3 is expected is an error unless the type is `Any`).
    pub(super) fn typed_input(
        &mut self,
        value: &Value,
        ty: InputType,
        what: &dyn std::fmt::Display,
        origin: &Origin,
    ) -> Option<NodeId> {
        let id = self.expression(value, origin)?;
        let actual = self.builder.ty(id);
        let ok = match ty {
            InputType::Any => true,
            InputType::Scalar => actual == Type::Scalar,
            InputType::Vec3 => actual == Type::Vec3,
        };
        if !ok {
            let expected = if ty == InputType::Scalar {
                "scalar"
            } else {
                "vec3"
            };
            let help = if ty == InputType::Scalar {
                "pick one component with \"id.x\", or reduce the vector with Length or Dot"
            } else {
                "build a point with Combine(x, y, z), or use Position"
            };
            self.error(
                Diagnostic::new(
                    Class::Type,
                    format!("{what} must be a {expected}, found a {actual}"),
                )
                .in_node(&*origin.node)
                .at(value.span)
                .label(format!("this is a {actual}"))
                .help(help),
            );
            return None;
        }
        Some(id)
    }

    pub(super) fn constant_scalar(
        &mut self,
        value: &Value,
        arg: &ArgDef,
        range: nodes::Range,
        def: &NodeDef,
        origin: &Origin,
    ) -> Option<f64> {
        let id = self.typed_input(
            value,
            InputType::Scalar,
            &ArgName(arg.name, def.name),
            origin,
        )?;
        let Some(v) = self.builder.const_scalar(id) else {
            self.error(
                Diagnostic::new(
                    Class::NotConstant,
                    format!("`{}` of {} must be a constant", arg.name, def.name),
                )
                .in_node(&*origin.node)
                .at(value.span)
                .label("varies per point")
                .help("use a number, a param, or an expression of those"),
            );
            return None;
        };
        if !v.is_finite() || !range.contains(v) {
            let label = if v.is_finite() && range.integer && v.fract() != 0.0 {
                "not an integer"
            } else {
                "out of range"
            };
            self.error(
                Diagnostic::new(
                    Class::BadParameter,
                    format!(
                        "`{}` of {} must be {}, got {}",
                        arg.name,
                        def.name,
                        range.describe(),
                        crate::diagnostic::number(v)
                    ),
                )
                .in_node(&*origin.node)
                .at(value.span)
                .label(label),
            );
            return None;
        }
        Some(v)
    }

    pub(super) fn constant_vec3(
        &mut self,
        value: &Value,
        what: &dyn std::fmt::Display,
        origin: &Origin,
    ) -> Option<[f64; 3]> {
        let id = self.expression(value, origin)?;
        let v = self.builder.const_vec3(id);
        match v {
            Some(v) if v.iter().all(|c| c.is_finite()) => Some(v),
            Some(_) => {
                self.error(
                    Diagnostic::new(Class::BadParameter, format!("{what} must be finite"))
                        .in_node(&*origin.node)
                        .at(value.span)
                        .label("not finite"),
                );
                None
            }
            None => {
                self.error(
                    Diagnostic::new(Class::NotConstant, format!("{what} must be a constant"))
                        .in_node(&*origin.node)
                        .at(value.span)
                        .label("varies per point")
                        .help("use (r, g, b) numbers or params"),
                );
                None
            }
        }
    }
}
