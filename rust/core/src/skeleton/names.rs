//! Left and right in bone names: the one rule of the project (the add-on and the roles of
//! `motion` use it).
//!
//! - [`mirror_name`]: Blender's left/right flip of a name (`thigh.L` <-> `thigh.R`);
//! - [`name_side`]: the side whose token that flip changes;
//! - [`bone_mirror_indices`]: each bone's mirror bone by name.
//!
//! The flip changes the first token found, rules tried in this order (exactly the add-on's
//! former Python `mirror_name`, a regular expression each):
//! 1. a suffix of a separator (`.` `_` `-` or space) and `L`/`l`: `thigh.L`, `shin-l`;
//! 2. the same with `R`/`r`;
//! 3. a prefix of `L`/`l` and a separator: `L_foot`, `l ear`;
//! 4. the same with `R`/`r`;
//! 5. the first `L`/`l`/`R`/`r` between two of `.` `_` `-` (not Blender's rule, but common in
//!    rigs from other tools): `leg_back_L_knee`, `Bip01_R_Thigh`, `hand_L.001`;
//! 6. the first `Left`, else `Right`, `left`, `right`, `LEFT`, `RIGHT` anywhere in the name:
//!    `mixamorig:LeftUpLeg`, `b_RightHand_011` (also inside a word: `Cleft` flips to `Cright`).
//!
//! Letters keep their case and separators stay. A name ending in a line feed is read as
//! Python's `$` reads it (the end is before the line feed).

use std::collections::HashMap;

/// Which side of the body (the character's own left/right).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    Left,
    Right,
}

/// Separators of a suffix or prefix side letter (rules 1 to 4).
const END_SEPARATORS: &[u8] = b"._- ";
/// Separators around a side letter inside a name (rule 5).
const INNER_SEPARATORS: &[u8] = b"._-";
/// Side words in the order they are looked for (rule 6): the word, its flip, its side.
const WORDS: [(&str, &str, Side); 6] = [
    ("Left", "Right", Side::Left),
    ("Right", "Left", Side::Right),
    ("left", "right", Side::Left),
    ("right", "left", Side::Right),
    ("LEFT", "RIGHT", Side::Left),
    ("RIGHT", "LEFT", Side::Right),
];

/// The token the flip changes: its byte range in the name, what replaces it, and its side.
struct Token {
    at: std::ops::Range<usize>,
    flipped: &'static str,
    side: Side,
}

/// A side letter (`L`, `l`, `R`, `r`): its flip and side.
fn letter(b: u8) -> Option<(&'static str, Side)> {
    match b {
        b'L' => Some(("R", Side::Left)),
        b'l' => Some(("r", Side::Left)),
        b'R' => Some(("L", Side::Right)),
        b'r' => Some(("l", Side::Right)),
        _ => None,
    }
}

/// The first token of the rules (module doc), if any. Every token is ASCII, so byte offsets are
/// character boundaries.
fn side_token(name: &str) -> Option<Token> {
    let b = name.as_bytes();
    let end = b.len() - usize::from(b.last() == Some(&b'\n'));
    let at_letter = |i: usize, side: Side| {
        letter(b[i]).filter(|&(_, s)| s == side).map(|(flipped, side)| Token { at: i..i + 1, flipped, side })
    };
    for side in [Side::Left, Side::Right] {
        if end >= 2 && END_SEPARATORS.contains(&b[end - 2]) {
            if let Some(t) = at_letter(end - 1, side) {
                return Some(t);
            }
        }
    }
    for side in [Side::Left, Side::Right] {
        if b.len() >= 2 && END_SEPARATORS.contains(&b[1]) {
            if let Some(t) = at_letter(0, side) {
                return Some(t);
            }
        }
    }
    let inner = b
        .windows(3)
        .position(|w| INNER_SEPARATORS.contains(&w[0]) && letter(w[1]).is_some() && INNER_SEPARATORS.contains(&w[2]));
    if let Some(i) = inner {
        let (flipped, side) = letter(b[i + 1])?;
        return Some(Token { at: i + 1..i + 2, flipped, side });
    }
    WORDS
        .iter()
        .find_map(|&(word, flipped, side)| name.find(word).map(|i| Token { at: i..i + word.len(), flipped, side }))
}

/// Blender's left/right flip of a bone name (see the module doc): `thigh.L` -> `thigh.R`,
/// `R_foot` -> `L_foot`, `leg_back_L_knee` -> `leg_back_R_knee`, `LeftArm` -> `RightArm`; the
/// name itself when it states no side.
pub fn mirror_name(name: &str) -> String {
    match side_token(name) {
        Some(t) => [&name[..t.at.start], t.flipped, &name[t.at.end..]].concat(),
        None => name.to_string(),
    }
}

/// The side a bone name states: the side of the token [`mirror_name`] flips (`thigh.L`: left,
/// `mixamorig:RightHand`: right), `None` for a name the flip leaves as it is (`spine`).
pub fn name_side(name: &str) -> Option<Side> {
    side_token(name).map(|t| t.side)
}

/// First characters of the runs of ten decimal digits (Unicode category Nd, as Python's `\d`
/// in Unicode 14, Blender 4's Python 3.11); the mathematical digits U+1D7CE..=U+1D7FF are the
/// one longer run.
const DIGIT_ZEROS: [u32; 61] = [
    0x30, 0x660, 0x6f0, 0x7c0, 0x966, 0x9e6, 0xa66, 0xae6, 0xb66, 0xbe6, 0xc66, 0xce6, 0xd66, 0xde6, 0xe50, 0xed0,
    0xf20, 0x1040, 0x1090, 0x17e0, 0x1810, 0x1946, 0x19d0, 0x1a80, 0x1a90, 0x1b50, 0x1bb0, 0x1c40, 0x1c50, 0xa620,
    0xa8d0, 0xa900, 0xa9d0, 0xa9f0, 0xaa50, 0xabf0, 0xff10, 0x104a0, 0x10d30, 0x11066, 0x110f0, 0x11136, 0x111d0,
    0x112f0, 0x11450, 0x114d0, 0x11650, 0x116c0, 0x11730, 0x118e0, 0x11950, 0x11c50, 0x11d50, 0x11da0, 0x16a60,
    0x16ac0, 0x16b50, 0x1e140, 0x1e2f0, 0x1e950, 0x1fbf0,
];

fn is_decimal_digit(c: char) -> bool {
    let c = c as u32;
    let zero = match DIGIT_ZEROS.binary_search(&c) {
        Ok(i) => DIGIT_ZEROS[i],
        Err(0) => return false,
        Err(i) => DIGIT_ZEROS[i - 1],
    };
    c - zero < 10 || (0x1d7ce..=0x1d7ff).contains(&c)
}

/// `name` without a trailing number and the one separator (`.` `_` `-`) before it: exporters
/// number nodes (`b_LeftHand_011` -> `b_LeftHand`).
fn unnumbered(name: &str) -> String {
    let (body, line_feed) = match name.strip_suffix('\n') {
        Some(body) => (body, "\n"),
        None => (name, ""),
    };
    let digits = body.trim_end_matches(is_decimal_digit);
    if digits.len() == body.len() {
        return name.to_string();
    }
    let stem = digits.strip_suffix(['.', '_', '-']).unwrap_or(digits);
    [stem, line_feed].concat()
}

/// Each bone's mirror bone by name: its index, the bone's own index for a centre bone (a name
/// [`mirror_name`] leaves as it is), -1 for a side bone without a partner.
///
/// The partner is the bone named [`mirror_name`] of the name (the last one, with duplicate
/// names), or else the one bone whose name matches it up to a trailing number
/// (`b_LeftUpperArm_09` <-> `b_RightUpperArm_06`). Pairs agree both ways: a bone whose partner
/// names another bone as its own gets -1.
pub fn bone_mirror_indices<S: AsRef<str>>(names: &[S]) -> Vec<i32> {
    let index: HashMap<&str, usize> = names.iter().enumerate().map(|(i, n)| (n.as_ref(), i)).collect();
    // per stem: its first bone and how many bones have it
    let mut by_stem: HashMap<String, (usize, usize)> = HashMap::new();
    for (i, n) in names.iter().enumerate() {
        by_stem.entry(unnumbered(n.as_ref())).or_insert((i, 0)).1 += 1;
    }
    let partner: Vec<Option<usize>> = names
        .iter()
        .enumerate()
        .map(|(i, n)| {
            let other = mirror_name(n.as_ref());
            if other == n.as_ref() {
                Some(i)
            } else if let Some(&j) = index.get(other.as_str()) {
                Some(j)
            } else {
                by_stem.get(&unnumbered(&other)).and_then(|&(first, count)| (count == 1).then_some(first))
            }
        })
        .collect();
    partner.iter().enumerate().map(|(i, &m)| m.filter(|&m| partner[m] == Some(i)).map_or(-1, |m| m as i32)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trailing_numbers_in_any_script_are_cut_with_one_separator() {
        assert_eq!(unnumbered("b_LeftHand_011"), "b_LeftHand");
        assert_eq!(unnumbered("x.5.12"), "x.5");
        assert_eq!(unnumbered("a-.5"), "a-");
        assert_eq!(unnumbered("bone12\n"), "bone\n");
        assert_eq!(unnumbered("spine"), "spine");
        assert_eq!(unnumbered("arm\u{ff11}\u{0663}"), "arm"); // fullwidth 1, Arabic-Indic 3
        assert_eq!(unnumbered("arm\u{1d7ff}"), "arm"); // mathematical monospace 9
        assert_eq!(unnumbered("arm\u{b2}"), "arm\u{b2}"); // a superscript 2 is no decimal digit
    }
}
