//! The formatter's layout rules.

mod common;

use common::parse_ok;

fn fmt(src: &str) -> String {
    let file = parse_ok(src);
    common::check_format_roundtrip(src, &file);
    mbdc_dsl::format(&file)
}

#[test]
fn messy_input_becomes_canonical() {
    let src = r#"// A messy scene.
import   "parts/link.mbd"
param L=1m;const  k = 2*pi*0.5Hz
component Arm( pivot ,len=1 m ){
body upper{mass 1kg
inertia rod(length:len,radius:5mm)}
   joint j=revolute( pivot,upper@(0,0,len/2),axis:(0,1,0) )  // hinge
}
model m{gravity(0,0,-9.81)m/s^2
  for i in 0 .. N{
    body link[ i ]{ mass 0.5 kg ; position ((i+0.5)*L,0,0) }
    if i==0{ a 1 }else if i==1{ b 2 }
    else { joint pin[i]=revolute(link[i-1]@(L/2,0,0),link[i]@(-L/2,0,0),axis:(0,1,0)) }
  }
  force f = point(arm.upper@(0,0,0),(1N * sin(2*pi*1Hz * t),0,0) , frame : body)
  x y = -a^2+(-a)^2+2^-1- -3*(b+c)/d%e
  flag z = not a==b and(c or d) ; list w = [1,2,] ; tuple u = (1,2,)
  simulate{duration 1s;step 1e-3 s
    method staggered{epsilon 1e-6}
    output{every 10;include bodies,energy}}
}
"#;
    insta::assert_snapshot!(fmt(src));
}

#[test]
fn blocks_of_properties_that_fit_are_printed_on_one_line() {
    assert_eq!(
        fmt("body b {\n  mass 1 kg\n  position (0, 0, 1) m\n}"),
        "body b { mass 1 kg; position (0, 0, 1) m }\n"
    );
    // Exactly at the width limit still fits; one more column does not.
    let fits = format!("b {{ p {} }}", "x".repeat(mbdc_dsl::MAX_WIDTH - 8));
    assert_eq!(fits.len(), mbdc_dsl::MAX_WIDTH);
    assert_eq!(fmt(&fits), format!("{fits}\n"));
    let too_long = format!("b {{ p {} }}", "x".repeat(mbdc_dsl::MAX_WIDTH - 7));
    assert_eq!(
        fmt(&too_long),
        format!("b {{\n  p {}\n}}\n", "x".repeat(mbdc_dsl::MAX_WIDTH - 7))
    );
    // Indentation counts towards the width.
    let nested = format!(
        "m {{\n  b {{ p {} }}\n}}\n",
        "x".repeat(mbdc_dsl::MAX_WIDTH - 9)
    );
    assert_eq!(
        fmt(&nested),
        format!(
            "m {{\n  b {{\n    p {}\n  }}\n}}\n",
            "x".repeat(mbdc_dsl::MAX_WIDTH - 9)
        )
    );
}

#[test]
fn blocks_with_declarations_or_comments_are_printed_on_several_lines() {
    assert_eq!(
        fmt("m { body b { mass 1 } }"),
        "m {\n  body b { mass 1 }\n}\n"
    );
    assert_eq!(fmt("b { mass 1 // kg\n}"), "b {\n  mass 1 // kg\n}\n");
    assert_eq!(
        fmt("b { // note\n mass 1 }"),
        "b {\n  // note\n  mass 1\n}\n"
    );
    assert_eq!(
        fmt("b { mass 1\n // end\n}"),
        "b {\n  mass 1\n  // end\n}\n"
    );
    assert_eq!(fmt("b { param x = 1 }"), "b {\n  param x = 1\n}\n");
    assert_eq!(fmt("b { joint j = f(x) }"), "b {\n  joint j = f(x)\n}\n");
}

#[test]
fn a_property_with_an_options_block_is_laid_out_like_a_declaration() {
    assert_eq!(
        fmt("mesh a {glue  r,fine.l{traction bessel( points:8 )}\nglue r,m.x{}\nfix r}"),
        "mesh a {\n  glue r, fine.l { traction bessel(points: 8) }\n  glue r, m.x {}\n  fix r\n}\n"
    );
    assert_eq!(
        fmt("glue r, m.l {\n  // why\n  traction polynomial(degree: 2)\n}"),
        "glue r, m.l {\n  // why\n  traction polynomial(degree: 2)\n}\n"
    );
}

#[test]
fn empty_blocks() {
    assert_eq!(fmt("simulate {\n\n}"), "simulate {}\n");
    assert_eq!(fmt("simulate { // later\n}"), "simulate {\n  // later\n}\n");
    assert_eq!(fmt("component C() {}"), "component C() {}\n");
}

#[test]
fn top_level_items_with_blocks_are_separated_by_a_blank_line() {
    let src = "import \"a.mbd\"\nparam N = 2\n// the arm\ncomponent A() { x 1 }\nmodel m { y 2 }\nconst c = 1\nconst d = 2\n";
    assert_eq!(
        fmt(src),
        "import \"a.mbd\"\nparam N = 2\n\n// the arm\ncomponent A() { x 1 }\n\nmodel m { y 2 }\n\nconst c = 1\nconst d = 2\n"
    );
    // Inside blocks, blank lines are the author's: a run is kept as one, none at the ends.
    assert_eq!(
        fmt("m {\n\n  a 1\n\n\n  b {}\n\n}\n"),
        "m {\n  a 1\n\n  b {}\n}\n"
    );
}

/// `mbdc fmt` deleted every blank line: a model's grouping (parameters, then bodies, then
/// joints) was lost on the first format. Blank lines are kept, runs collapsed to one, at
/// every level and around comments; none at the start or end of a block or file.
#[test]
fn blank_lines_between_items_are_kept() {
    let src = "\n\n// header\n\n\n// about m\nmodel m {\n\n  param L = 1 m\n  param M = 2 kg\n\n\n\n  // bodies\n\n  body a { mass M }\n  body b {\n    mass M\n\n    inertia sphere(radius: L)\n  }\n\n  // the end\n\n}\n\n// tail\n\n";
    assert_eq!(
        fmt(src),
        "// header\n\n// about m\nmodel m {\n  param L = 1 m\n  param M = 2 kg\n\n  // bodies\n\n  body a { mass M }\n  body b {\n    mass M\n\n    inertia sphere(radius: L)\n  }\n\n  // the end\n}\n\n// tail\n"
    );
    // a block whose properties the author separated stays on several lines
    assert_eq!(fmt("b {\n  a 1\n\n  c 2\n}\n"), "b {\n  a 1\n\n  c 2\n}\n");
    assert_eq!(fmt("b {\n  a 1\n  c 2\n}\n"), "b { a 1; c 2 }\n");
    // items on one line have no blank line between them
    assert_eq!(fmt("m {\n  a 1; b 2\n}\n"), "m { a 1; b 2 }\n");
}

#[test]
fn else_if_chains() {
    assert_eq!(
        fmt("if a {\n x 1\n} else {\n if b { x 2 } else { x 3 }\n}"),
        "if a { x 1 } else if b { x 2 } else { x 3 }\n"
    );
    // A comment on the inner `if` keeps the explicit block.
    assert_eq!(
        fmt("if a {\n x 1\n} else {\n // other\n if b { x 2 }\n}"),
        "if a {\n  x 1\n} else {\n  // other\n  if b { x 2 }\n}\n"
    );
    // A chain is on one line only if all its blocks are; otherwise all are on several.
    assert_eq!(
        fmt("if a { m { n 1 } } else if b { x 2 } else { y 3 }"),
        "if a {\n  m { n 1 }\n} else if b {\n  x 2\n} else {\n  y 3\n}\n"
    );
    let long = format!("if a {{ x 1 }} else {{ y {} }}", "z".repeat(90));
    assert_eq!(
        fmt(&long),
        format!("if a {{\n  x 1\n}} else {{\n  y {}\n}}\n", "z".repeat(90))
    );
}

#[test]
fn comments_are_kept_in_place() {
    let src = "// file\n\n// model\nmodel m { // brace\n  a 1 /* a */\n  /* b */ b 2\n}  // after\n/* end */\n";
    assert_eq!(
        fmt(src),
        "// file\n\n// model\nmodel m {\n  // brace\n  a 1 /* a */\n  /* b */\n  b 2\n} // after\n/* end */\n"
    );
    // Multi-line block comments are printed verbatim.
    assert_eq!(
        fmt("  /* one\n     two */\n  a 1\n"),
        "/* one\n     two */\na 1\n"
    );
    assert_eq!(fmt("// only a comment"), "// only a comment\n");
}

#[test]
fn expressions_are_spaced_canonically() {
    let e = |s: &str| {
        mbdc_dsl::format_expr(&mbdc_dsl::parse_expr(s).unwrap_or_else(|e| panic!("{e:?}")))
    };
    assert_eq!(e("a+b*c"), "a + b * c");
    assert_eq!(e("x ^ 2"), "x^2");
    assert_eq!(e("2 m ^ 2"), "2 m ^ 2");
    assert_eq!(e("(x) m ^ 2"), "(x) m ^ 2");
    assert_eq!(e("2m"), "2 m");
    assert_eq!(e("2\tkg*m^2"), "2 kg*m^2");
    assert_eq!(e("(x)m"), "(x) m");
    assert_eq!(e("f( a , b : 1 )"), "f(a, b: 1)");
    assert_eq!(e("[ 1,2 , ]"), "[1, 2]");
    assert_eq!(e("( 1,2 , )"), "(1, 2)");
    assert_eq!(e("- - x"), "--x");
    assert_eq!(e("a - - x"), "a - -x");
    assert_eq!(e("not(a)"), "not (a)");
    assert_eq!(e("a  @  b"), "a @ b");
    assert_eq!(e("x>=1 and y!=2"), "x >= 1 and y != 2");
}

#[test]
fn literals_keep_their_text() {
    let e = |s: &str| {
        mbdc_dsl::format_expr(&mbdc_dsl::parse_expr(s).unwrap_or_else(|e| panic!("{e:?}")))
    };
    for s in [
        "1e-6",
        "6.02E23",
        "1.50",
        "007",
        "1e+3",
        "0.1 N*s/m",
        "10 1/s",
        "3 s^-1",
    ] {
        assert_eq!(e(s), s);
    }
    assert_eq!(e(r#""a \"b\" \\ c\nd""#), r#""a \"b\" \\ c\nd""#);
    assert_eq!(e("\"tab\there\""), "\"tab\there\"");
}

#[test]
fn empty_file_and_line_endings() {
    assert_eq!(fmt(""), "");
    assert_eq!(fmt("\n\n"), "");
    assert_eq!(
        fmt("a 1\r\nb {\r\n  c 2 // x\r\n}\r\n"),
        "a 1\n\nb {\n  c 2 // x\n}\n"
    );
}

#[test]
fn nested_chains_are_laid_out_in_linear_time() {
    // Each level is laid out once: an exponential layout would not finish.
    let n = 120;
    let src = format!(
        "{}x 1{}",
        "if a { y 2\n".repeat(n),
        "\n} else { z 3 }".repeat(n)
    );
    let out = fmt(&src);
    assert_eq!(out.lines().count(), 5 * n + 1);
}

/// A material's `plastic { yield ...; hardening ... }` block: a declaration without a name,
/// so the material is laid out on several lines and the plastic block, which fits, on one;
/// formatting is idempotent (checked by `fmt`'s round trip) and keeps the units.
#[test]
fn plastic_material_blocks() {
    assert_eq!(
        fmt("material steel { E 210 GPa; nu 0.3; rho 7850 kg/m^3; plastic {yield 250 MPa\n hardening 1 GPa} }"),
        "material steel {\n  E 210 GPa\n  nu 0.3\n  rho 7850 kg/m^3\n  plastic { yield 250 MPa; hardening 1 GPa }\n}\n"
    );
    assert_eq!(
        fmt("material m {\n  E 1 Pa\n  plastic {\n    yield 2 Pa // initial\n  }\n}\n"),
        "material m {\n  E 1 Pa\n  plastic {\n    yield 2 Pa // initial\n  }\n}\n"
    );
}
