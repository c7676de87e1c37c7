//! WGSL assembly: shared include files and typed constants, so that no shader is put
//! together by replacing placeholder text.
//!
//! An include line is a line whose text (after leading whitespace) is `//! include NAME`,
//! where NAME is one of [`INCLUDES`] (or one added with [`WgslAssembler::with_include`]). It
//! is replaced by that file's text, whose own include lines are resolved in turn; every file
//! is included at most once per assembly (a later line naming it again adds nothing, so
//! cycles end). An unknown name or a malformed include line is a [`GpuError::Include`]
//! naming the file and the line. Other `//!` lines (`//! includes ...` too) are ordinary
//! comments.
//!
//! Constants ([`WgslAssembler::constant_f32`] and friends) become `const NAME: TYPE = ...;`
//! declarations at the top of the assembled text, floats written as the shortest decimal
//! that reads back as the same `f32`, with an `f` suffix (so naga reads them as f32 and not
//! through an abstract float).
//!
//! Adding an include file is one line in [`INCLUDES`].

use std::collections::HashSet;
use std::fmt::Write as _;

use crate::GpuError;

/// The shared include files compiled into the binary: `(name, text)`. One line each.
pub const INCLUDES: &[(&str, &str)] = &[
    // sRGB transfer functions, the WGSL twin of `study::color`.
    ("srgb", include_str!("../shaders/srgb.wgsl")),
];

/// A typed constant's WGSL type and value, as text.
#[derive(Clone, Debug)]
struct Constant {
    name: String,
    ty: &'static str,
    value: Result<String, String>,
}

/// Assembles WGSL from a main file, include files and typed constants.
#[derive(Clone, Debug)]
pub struct WgslAssembler {
    includes: Vec<(&'static str, &'static str)>,
    constants: Vec<Constant>,
}

impl Default for WgslAssembler {
    fn default() -> Self {
        WgslAssembler::new()
    }
}

/// An `f32` as a WGSL f32 literal that reads back as the same bits (`None` for NaN and the
/// infinities, which WGSL cannot write).
fn f32_literal(v: f32) -> Option<String> {
    if !v.is_finite() {
        return None;
    }
    // `{:?}` is the shortest decimal that round-trips; it may read "1e-7" or "1e20".
    let text = format!("{v:?}");
    let text = match text.split_once('e') {
        Some((mantissa, exponent)) if !mantissa.contains('.') => format!("{mantissa}.0e{exponent}"),
        _ => text,
    };
    Some(format!("{text}f"))
}

fn is_identifier(name: &str) -> bool {
    let mut chars = name.chars();
    chars.next().is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
        && name != "_"
        && !name.starts_with("__")
}

impl WgslAssembler {
    /// An assembler knowing the shared [`INCLUDES`] and no constants.
    pub fn new() -> Self {
        WgslAssembler { includes: INCLUDES.to_vec(), constants: Vec::new() }
    }

    /// Adds (or replaces) an include file known by `name`, e.g. a crate's own shared file.
    pub fn with_include(mut self, name: &'static str, text: &'static str) -> Self {
        self.includes.retain(|(n, _)| *n != name);
        self.includes.push((name, text));
        self
    }

    fn constant(&mut self, name: &str, ty: &'static str, value: Result<String, String>) -> &mut Self {
        self.constants.push(Constant { name: name.to_owned(), ty, value });
        self
    }

    /// `const NAME: f32 = v;` (v must be finite).
    pub fn constant_f32(&mut self, name: &str, v: f32) -> &mut Self {
        let value = f32_literal(v).ok_or_else(|| format!("{v} is not finite; WGSL has no literal for it"));
        self.constant(name, "f32", value)
    }

    /// `const NAME: u32 = v;`.
    pub fn constant_u32(&mut self, name: &str, v: u32) -> &mut Self {
        self.constant(name, "u32", Ok(format!("{v}u")))
    }

    /// `const NAME: i32 = v;`.
    pub fn constant_i32(&mut self, name: &str, v: i32) -> &mut Self {
        // i32::MIN has no positive literal to negate: written as an expression.
        let text = if v == i32::MIN { "(-2147483647i - 1i)".to_owned() } else { format!("{v}i") };
        self.constant(name, "i32", Ok(text))
    }

    /// `const NAME: vec3<f32> = vec3<f32>(v[0], v[1], v[2]);`.
    pub fn constant_vec3(&mut self, name: &str, v: [f32; 3]) -> &mut Self {
        let value = vec3(v);
        self.constant(name, "vec3<f32>", value)
    }

    /// A 3x3 matrix given row by row (`m[row][column]`, as Rust code writes matrices):
    /// `const NAME: mat3x3<f32> = mat3x3<f32>(column 0, column 1, column 2);`, so that in WGSL
    /// `NAME * v` is the matrix times the column vector `v` and `NAME[c][r]` is `m[r][c]`.
    pub fn constant_mat3x3(&mut self, name: &str, m: [[f32; 3]; 3]) -> &mut Self {
        let columns: Result<Vec<String>, String> = (0..3).map(|c| vec3([m[0][c], m[1][c], m[2][c]])).collect();
        let value = columns.map(|c| format!("mat3x3<f32>({})", c.join(", ")));
        self.constant(name, "mat3x3<f32>", value)
    }

    /// The declarations of the constants, checked (identifiers, each once, finite values).
    fn declarations(&self) -> Result<String, GpuError> {
        let mut names = HashSet::new();
        let mut out = String::new();
        for c in &self.constants {
            let bad = |message: String| GpuError::Constant { name: c.name.clone(), message };
            if !is_identifier(&c.name) {
                return Err(bad("not a WGSL identifier".into()));
            }
            if !names.insert(c.name.as_str()) {
                return Err(bad("given twice".into()));
            }
            let value = c.value.clone().map_err(bad)?;
            let _ = writeln!(out, "const {}: {} = {};", c.name, c.ty, value);
        }
        Ok(out)
    }

    /// The WGSL of `source` (read from the file `file`, the name errors give) with its include
    /// lines resolved and the constants declared first.
    pub fn assemble(&self, file: &str, source: &str) -> Result<String, GpuError> {
        let mut out = String::new();
        let declarations = self.declarations()?;
        if !declarations.is_empty() {
            out.push_str("// Constants from the assembler.\n");
            out.push_str(&declarations);
        }
        let mut included = HashSet::new();
        self.expand(file, source, &mut included, &mut out)?;
        Ok(out)
    }

    fn expand<'a>(
        &'a self,
        file: &str,
        source: &str,
        included: &mut HashSet<&'a str>,
        out: &mut String,
    ) -> Result<(), GpuError> {
        for (i, line) in source.lines().enumerate() {
            let directive = line.trim_start().strip_prefix("//! include");
            // `//! includes ...` and the like are comments.
            let Some(rest) = directive.filter(|r| r.is_empty() || r.starts_with(char::is_whitespace)) else {
                out.push_str(line);
                out.push('\n');
                continue;
            };
            let error = |message: String| GpuError::Include { file: file.to_owned(), line: i + 1, message };
            let mut words = rest.split_whitespace();
            let (Some(name), None) = (words.next(), words.next()) else {
                return Err(error(format!("malformed include line {line:?}: expected `//! include NAME`")));
            };
            let Some(&(name, text)) = self.includes.iter().find(|(n, _)| *n == name) else {
                let known: Vec<&str> = self.includes.iter().map(|(n, _)| *n).collect();
                return Err(error(format!("unknown include {name:?} (known: {})", known.join(", "))));
            };
            if included.insert(name) {
                let _ = writeln!(out, "// ---- include {name} ----");
                self.expand(&format!("{name}.wgsl"), text, included, out)?;
                let _ = writeln!(out, "// ---- end of include {name} ----");
            }
        }
        Ok(())
    }
}

fn vec3(v: [f32; 3]) -> Result<String, String> {
    let parts: Option<Vec<String>> = v.iter().map(|&x| f32_literal(x)).collect();
    parts.map(|p| format!("vec3<f32>({})", p.join(", "))).ok_or_else(|| format!("{v:?} has a value that is not finite"))
}

/// Parses and validates WGSL with naga on the CPU (no device needed); `file` names it in the
/// error. Returns naga's module.
pub fn validate_wgsl(file: &str, source: &str) -> Result<wgpu::naga::Module, GpuError> {
    use wgpu::naga;
    let module = naga::front::wgsl::parse_str(source)
        .map_err(|e| GpuError::Wgsl { file: file.to_owned(), message: e.emit_to_string_with_path(source, file) })?;
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::all())
        .validate(&module)
        .map_err(|e| GpuError::Wgsl { file: file.to_owned(), message: e.emit_to_string_with_path(source, file) })?;
    Ok(module)
}

#[cfg(test)]
mod tests {
    use wgpu::naga;

    use super::*;

    const A: &str = "//! include b\nfn a() -> f32 { return b(); }\n";
    const B: &str = "  //! include c\nfn b() -> f32 { return c(); }\n";
    const C: &str = "//! a doc comment, not an include\n//! includes b, which is fine\n//! include b\nfn c() -> f32 { return 1.0; }\n";

    fn assembler() -> WgslAssembler {
        WgslAssembler::new().with_include("a", A).with_include("b", B).with_include("c", C)
    }

    #[test]
    fn nested_includes_are_resolved_once_each() {
        let main = "//! include a\n//! include c\n//! include srgb\n@compute @workgroup_size(1) fn main() { let x = a() + srgb_encode(0.5); }\n";
        let wgsl = assembler().assemble("main.wgsl", main).unwrap();
        for name in ["fn a()", "fn b()", "fn c()", "fn srgb_encode("] {
            assert_eq!(wgsl.matches(name).count(), 1, "{name} in:\n{wgsl}");
        }
        // Included before use, in the order the lines name them (c inside b inside a).
        let at = |s: &str| wgsl.find(s).unwrap();
        assert!(at("fn c()") < at("fn b()") && at("fn b()") < at("fn a()"), "{wgsl}");
        // The doc comment stays a comment; no include line is left.
        assert!(wgsl.contains("//! a doc comment, not an include\n//! includes b, which is fine\n"));
        assert!(!wgsl.lines().any(|l| l.trim_start().starts_with("//! include ")), "{wgsl}");
        validate_wgsl("main.wgsl", &wgsl).unwrap();
    }

    #[test]
    fn an_unknown_or_malformed_include_names_the_file_and_line() {
        let e = assembler().assemble("main.wgsl", "fn f() {}\n\n//! include nope\n").unwrap_err();
        assert!(matches!(&e, GpuError::Include { file, line: 3, .. } if file == "main.wgsl"), "{e:?}");
        let text = e.to_string();
        assert!(text.starts_with("main.wgsl:3: unknown include \"nope\" (known: srgb, a, b, c)"), "{text}");
        // Inside an included file: that file and its line.
        let e = WgslAssembler::new()
            .with_include("x", "fn x() {}\n//! include y\n")
            .assemble("main.wgsl", "//! include x\n")
            .unwrap_err();
        assert_eq!(e.to_string(), "x.wgsl:2: unknown include \"y\" (known: srgb, x)");
        for bad in ["//! include", "//! include a b", "  //! include\ta\tb"] {
            let e = assembler().assemble("m.wgsl", bad).unwrap_err().to_string();
            assert!(e.starts_with("m.wgsl:1: malformed include line"), "{bad}: {e}");
        }
    }

    /// The value naga reads for the constant `name` of `module`.
    fn naga_constant(module: &naga::Module, name: &str) -> Vec<naga::Literal> {
        let (_, c) = module.constants.iter().find(|(_, c)| c.name.as_deref() == Some(name)).unwrap();
        let mut out = Vec::new();
        let mut stack = vec![c.init];
        while let Some(h) = stack.pop() {
            match &module.global_expressions[h] {
                naga::Expression::Literal(l) => out.push(*l),
                naga::Expression::Compose { components, .. } => stack.extend(components.iter().rev()),
                other => panic!("{name}: not folded to literals: {other:?}"),
            }
        }
        out
    }

    #[test]
    fn typed_constants_round_trip_exactly_through_naga() {
        let tricky = [
            0.1f32,
            -0.5,
            1.0 / 3.0,
            1e-7,
            1e20,
            f32::MIN_POSITIVE,
            f32::MAX,
            -f32::MAX,
            f32::EPSILON,
            0.003_130_8,
            12.92,
            -0.0,
            2.0,
        ];
        let mut a = WgslAssembler::new();
        for (i, v) in tricky.iter().enumerate() {
            a.constant_f32(&format!("F{i}"), *v);
        }
        let m = [[0.456_1, 0.500_484, 0.176_381], [-0.040_034_1, -0.037_875_7, -0.015_759_8], [1.0, 2.5e-8, -3.0]];
        a.constant_mat3x3("M", m).constant_vec3("V", [0.25, -1e-3, 7.0]);
        a.constant_u32("U", u32::MAX).constant_i32("I", i32::MIN).constant_i32("J", -7);
        let wgsl = a.assemble("consts.wgsl", "").unwrap();
        assert!(wgsl.contains("const F0: f32 = 0.1f;"), "{wgsl}");
        assert!(wgsl.contains("const F3: f32 = 1.0e-7f;"), "{wgsl}");
        let module = validate_wgsl("consts.wgsl", &wgsl).unwrap();
        for (i, v) in tricky.iter().enumerate() {
            let got = naga_constant(&module, &format!("F{i}"));
            assert_eq!(got.len(), 1);
            let naga::Literal::F32(g) = got[0] else { panic!("F{i}: {:?}", got[0]) };
            assert_eq!(g.to_bits(), v.to_bits(), "F{i}: {v:?} read back as {g:?}\n{wgsl}");
        }
        // Column-major: the literals come column by column.
        let columns: Vec<u32> = (0..3).flat_map(|c| (0..3).map(move |r| m[r][c].to_bits())).collect();
        let got: Vec<u32> = naga_constant(&module, "M")
            .iter()
            .map(|l| match l {
                naga::Literal::F32(v) => v.to_bits(),
                other => panic!("{other:?}"),
            })
            .collect();
        assert_eq!(got, columns);
        assert_eq!(naga_constant(&module, "V"), [0.25f32, -1e-3, 7.0].map(naga::Literal::F32));
        assert_eq!(naga_constant(&module, "U"), [naga::Literal::U32(u32::MAX)]);
        assert_eq!(naga_constant(&module, "I"), [naga::Literal::I32(i32::MIN)]);
        assert_eq!(naga_constant(&module, "J"), [naga::Literal::I32(-7)]);
    }

    /// The error assembling with the constants `add` declares.
    fn refused(add: impl FnOnce(&mut WgslAssembler)) -> String {
        let mut a = WgslAssembler::new();
        add(&mut a);
        a.assemble("m.wgsl", "").unwrap_err().to_string()
    }

    #[test]
    fn bad_constants_are_refused_by_name() {
        assert_eq!(
            refused(|a| {
                a.constant_f32("X", f32::NAN);
            }),
            "WGSL constant X: NaN is not finite; WGSL has no literal for it"
        );
        assert_eq!(
            refused(|a| {
                a.constant_vec3("X", [1.0, f32::INFINITY, 0.0]);
            }),
            "WGSL constant X: [1.0, inf, 0.0] has a value that is not finite"
        );
        assert_eq!(
            refused(|a| {
                a.constant_u32("9X", 1);
            }),
            "WGSL constant 9X: not a WGSL identifier"
        );
        assert_eq!(
            refused(|a| {
                a.constant_u32("X", 1).constant_f32("X", 1.0);
            }),
            "WGSL constant X: given twice"
        );
    }

    #[test]
    fn the_shared_includes_compile() {
        for (name, _) in INCLUDES {
            let wgsl = WgslAssembler::new().assemble("main.wgsl", &format!("//! include {name}\n")).unwrap();
            validate_wgsl(&format!("{name}.wgsl"), &wgsl).unwrap();
        }
    }
}
