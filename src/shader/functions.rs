//! The export's module made for its target on naga's IR, after parsing: the functions an export
//! writes for itself (`fn NAME__export`: the f32 forms and the table readers, appended to the
//! source under a suffixed name) take the place of the library's `NAME`, and every module-scope
//! name but the exported ones gets the `tg_` prefix so that nothing collides with the user's
//! shader.

use super::options::PREFIX;
use crate::gpu::ir::{map_calls, order_by_calls, signature};
use naga::{Function, Handle, Module};
use std::collections::HashSet;

/// Each function named `NAME{suffix}` replaces `NAME`: its body and signature go to `NAME`'s
/// handle, so every call of `NAME` calls it; the replacement's own entry is left unused, for
/// compaction. The functions are then put back in an order where each follows the functions
/// it calls (naga's validator and writers need it; a replacement may call functions defined
/// after the one it replaces). The names of replacements without a function to replace are
/// an error.
pub fn replace(module: &mut Module, suffix: &str) -> Result<(), String> {
    let handles: std::collections::HashMap<String, Handle<Function>> = module
        .functions
        .iter()
        .filter_map(|(h, f)| Some((f.name.clone()?, h)))
        .collect();
    // In name order, so that the first missing function is always the same one.
    let mut replacements: Vec<(&String, Handle<Function>)> = handles
        .iter()
        .filter(|(name, _)| name.ends_with(suffix))
        .map(|(name, &h)| (name, h))
        .collect();
    replacements.sort();
    let mut replaced = false;
    for (name, with) in replacements {
        let Some(base) = name.strip_suffix(suffix) else {
            continue;
        };
        let Some(&target) = handles.get(base) else {
            return Err(format!(
                "`{name}` replaces `{base}`, which the module lacks"
            ));
        };
        let mut f = module.functions[with].clone();
        f.name = Some(base.to_string());
        module.functions[target] = f;
        replaced = true;
    }
    if replaced {
        order_by_calls(module);
    }
    Ok(())
}

/// Points every call of the function `from` at the function `to`, which must have the same
/// signature in `module` (after narrowing, `s_ldexp` and `d_ldexp` are one function): `from`
/// is left unused, for compaction, and the functions ordered again by their calls.
pub fn redirect(module: &mut Module, from: &str, to: &str) -> Result<(), String> {
    let find = |name: &str| {
        module
            .functions
            .iter()
            .find(|(_, f)| f.name.as_deref() == Some(name))
            .map(|(h, _)| h)
    };
    let (Some(from), Some(to)) = (find(from), find(to)) else {
        return Ok(());
    };
    if signature(&module.functions[from]) != signature(&module.functions[to]) {
        let name = |h: Handle<Function>| module.functions[h].name.clone().unwrap_or_default();
        return Err(format!(
            "`{}` and `{}` differ in their signatures",
            name(from),
            name(to)
        ));
    }
    map_calls(module, |h| if h == from { to } else { h });
    order_by_calls(module);
    Ok(())
}

/// Renames every named function, constant, global variable and type of `module` to
/// [`PREFIX`]`name`, but for those in `keep` (the exported functions, the stub entry point's,
/// the uniform block's struct and instance). Struct members keep their names.
pub fn prefix(module: &mut Module, keep: &HashSet<String>) {
    let rename = |name: &mut Option<String>| {
        if let Some(n) = name.as_mut().filter(|n| !keep.contains(n.as_str())) {
            n.insert_str(0, PREFIX);
        }
    };
    for (_, f) in module.functions.iter_mut() {
        rename(&mut f.name);
    }
    for (_, c) in module.constants.iter_mut() {
        rename(&mut c.name);
    }
    for (_, g) in module.global_variables.iter_mut() {
        rename(&mut g.name);
    }
    let named: Vec<_> = module
        .types
        .iter()
        .filter(|(_, t)| t.name.is_some())
        .map(|(h, t)| (h, t.clone()))
        .collect();
    for (h, mut t) in named {
        rename(&mut t.name);
        if t.name != module.types[h].name {
            // In place: a prefixed name is new to the arena, so the handle stays.
            module.types.replace(h, t);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use naga::valid::{Capabilities, ValidationFlags, Validator};

    #[test]
    fn a_replacement_takes_the_place_and_the_order_follows_the_calls() {
        // `f`'s replacement calls `h`, which the front end places after `f` and `g`.
        let mut module = naga::front::wgsl::parse_str(
            "fn f() -> f32 { return 1.0; }
             fn g() -> f32 { return f() + 1.0; }
             fn h() -> f32 { return 2.0 * g_unused(); }
             fn g_unused() -> f32 { return 3.0; }
             fn f__export() -> f32 { return h(); }
             struct S { cell: f32 }
             @fragment fn keep() -> @location(0) vec4<f32> {
                 let s = S(g());
                 return vec4<f32>(s.cell);
             }",
        )
        .unwrap();
        replace(&mut module, "__export").unwrap();
        naga::compact::compact(&mut module, naga::compact::KeepUnused::No);
        prefix(&mut module, &HashSet::from(["g".to_string()]));
        let info = Validator::new(ValidationFlags::all(), Capabilities::empty())
            .validate(&module)
            .expect("callees before callers");
        let names: Vec<_> = module
            .functions
            .iter()
            .filter_map(|(_, f)| f.name.clone())
            .collect();
        // The replacement's own entry is gone with compaction; `f` now calls `h`.
        assert_eq!(names, ["tg_g_unused", "tg_h", "tg_f", "g"]);
        let text =
            naga::back::wgsl::write_string(&module, &info, naga::back::wgsl::WriterFlags::empty())
                .unwrap();
        assert!(text.contains("struct tg_S {\n    cell: f32"), "{text}");
        assert!(!text.contains("return 1f"), "{text}");
    }

    #[test]
    fn a_redirected_function_is_called_no_more() {
        let mut module = naga::front::wgsl::parse_str(
            "fn a(x: f32) -> f32 { return x * 2.0; }
             fn b(x: f32) -> f32 { return x + x; }
             fn c(x: i32) -> f32 { return f32(x); }
             @fragment fn keep() -> @location(0) vec4<f32> { return vec4<f32>(a(1.0)); }",
        )
        .unwrap();
        assert!(redirect(&mut module, "a", "c")
            .unwrap_err()
            .contains("signatures"));
        redirect(&mut module, "a", "b").unwrap();
        naga::compact::compact(&mut module, naga::compact::KeepUnused::No);
        let names: Vec<_> = module
            .functions
            .iter()
            .filter_map(|(_, f)| f.name.clone())
            .collect();
        assert_eq!(names, ["b"]);
        Validator::new(ValidationFlags::all(), Capabilities::empty())
            .validate(&module)
            .expect("valid");
    }

    #[test]
    fn a_replacement_of_nothing_is_an_error() {
        let mut module =
            naga::front::wgsl::parse_str("fn lonely__export() -> f32 { return 1.0; }").unwrap();
        let e = replace(&mut module, "__export").unwrap_err();
        assert!(e.contains("`lonely`"), "{e}");
    }
}
