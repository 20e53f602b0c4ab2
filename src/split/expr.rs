//! The filter language of `minos split --where`: a boolean expression over one manifest row.
//!
//! This module turns text into a checked [`Expr`] and evaluates it on a [`ManifestRow`]; it
//! knows nothing about splits or files. Work happens in three stages, each with its own
//! errors, all reported as one line with a 1-based column ([`ExprError`]):
//!
//! 1. the lexer cuts the text into tokens (bad characters, numbers and strings);
//! 2. a recursive-descent parser builds an untyped syntax tree and resolves names (unknown
//!    columns and functions, misplaced tokens);
//! 3. `check` gives every node a type and builds the typed tree (comparing a string with a
//!    number, using a number where a condition is needed).
//!
//! So every mistake is found before any row is evaluated, and evaluation cannot fail.
//!
//! Grammar (precedence from loosest to tightest: `||`, `&&`, comparisons, `!`):
//!
//! ```text
//! expr    := and ( "||" and )*
//! and     := cmp ( "&&" cmp )*
//! cmp     := unary ( ("==" | "!=" | "<" | "<=" | ">" | ">=") unary )?
//! unary   := "!" unary | primary
//! primary := NUMBER | STRING | COLUMN | FUNCTION "(" STRING ")" | "(" expr ")"
//! ```
//!
//! Comparisons take two numbers or two strings (strings compare exactly, byte-wise); they do
//! not chain. See [`SYNTAX_HELP`] for the columns and functions.

use std::fmt;

use crate::scene::RoomClass;
use crate::store::manifest::ManifestRow;

/// The language in a few lines, as `minos split --help` shows it.
pub const SYNTAX_HELP: &str = "\
Filter expressions select manifest rows:
  comparisons     ==  !=  <  <=  >  >=   between two numbers or two strings
  logic           !  (not)   &&  (and)   ||  (or)   ( ) to group
  precedence      ! binds tightest, then comparisons, then &&, then ||
                  (so negate a comparison as !(nrooms == 2), not !nrooms == 2)
  numbers         2   50.5   -1.5   1e3
  strings         \"suncg\" in double quotes (escape \\\" and \\\\); compared exactly
  string columns  id, dataset, source_path
  number columns  nlevels, nrooms, nobjects, floor_area (m²), ntriangles,
                  bbox_min_x, bbox_min_y, bbox_min_z, bbox_max_x, bbox_max_y, bbox_max_z,
                  size_x, size_y, size_z (extents of the scene box, m)
  has_room(\"kitchen\")   a room of that MINOS class (aliases such as \"lounge\" work:
                        other, bedroom, living_room, bathroom, kitchen, dining_room,
                        office, hallway, outdoor) or with that raw room type, any case
  has_category(\"door\")  an object with that fine or coarse category, any case";

/// A checked filter expression; [`Expr::matches`] evaluates it on a manifest row.
#[derive(Debug, Clone, PartialEq)]
pub struct Expr {
    source: String,
    root: Cond,
}

impl Expr {
    /// Parses and type-checks `source`.
    pub fn parse(source: &str) -> Result<Expr, ExprError> {
        let tokens = lex(source)?;
        let end = source.chars().count() + 1;
        if tokens.is_empty() {
            return Err(ExprError::new(1, ExprErrorKind::Empty));
        }
        let mut parser = Parser {
            tokens,
            pos: 0,
            open: 0,
            end,
        };
        let tree = parser.or()?;
        if let Some(t) = parser.peek() {
            let kind = ExprErrorKind::Unexpected {
                found: t.tok.describe(),
                expected: "`&&`, `||` or the end of the expression",
            };
            return Err(ExprError::new(t.col, kind));
        }
        let root = check_cond(&tree, "the expression")?;
        Ok(Expr {
            source: source.to_string(),
            root,
        })
    }

    /// True when `row` satisfies the expression.
    pub fn matches(&self, row: &ManifestRow) -> bool {
        self.root.eval(row)
    }

    /// The text the expression was parsed from.
    pub fn source(&self) -> &str {
        &self.source
    }
}

impl fmt::Display for Expr {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.source)
    }
}

/// A mistake in a filter expression and where it is.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("at column {column}: {kind}")]
pub struct ExprError {
    /// 1-based character column of the offending token.
    pub column: usize,
    /// What is wrong.
    pub kind: ExprErrorKind,
}

impl ExprError {
    fn new(column: usize, kind: ExprErrorKind) -> Self {
        ExprError { column, kind }
    }
}

/// What is wrong with a filter expression.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ExprErrorKind {
    /// Nothing but white space.
    #[error("empty expression")]
    Empty,
    /// A character that starts no token.
    #[error("unexpected character `{found}`{}", hint_suffix(*.hint))]
    UnexpectedChar {
        /// The character.
        found: char,
        /// What was probably meant.
        hint: Option<&'static str>,
    },
    /// A string literal without its closing quote.
    #[error("string is not closed: a `\"` is missing")]
    UnterminatedString,
    /// A backslash escape other than `\"` and `\\`.
    #[error("unknown escape `\\{0}` in string (only \\\" and \\\\ are known)")]
    BadEscape(char),
    /// A malformed or infinite number literal.
    #[error("`{0}` is not a number")]
    BadNumber(String),
    /// A token where another was needed.
    #[error("expected {expected}, found {found}")]
    Unexpected {
        /// The token found (or "the end of the expression").
        found: String,
        /// What would have been valid.
        expected: &'static str,
    },
    /// `a < b < c`.
    #[error("comparisons cannot be chained: write `a < b && b < c`")]
    ChainedComparison,
    /// An identifier that is neither a column nor a function.
    #[error("unknown column `{name}` (known: {})", column_names())]
    UnknownColumn {
        /// The identifier.
        name: String,
    },
    /// `name(…)` where `name` is no function.
    #[error("unknown function `{name}` (known: has_room, has_category)")]
    UnknownFunction {
        /// The identifier.
        name: String,
    },
    /// A function without its single string argument.
    #[error("`{function}` takes one string in double quotes, e.g. {function}(\"{example}\")")]
    BadArgument {
        /// The function.
        function: &'static str,
        /// A valid argument.
        example: &'static str,
    },
    /// A comparison between a string and a number.
    #[error("cannot compare {left} with {right}")]
    Mismatch {
        /// The left operand, described (`string column \`dataset\``).
        left: String,
        /// The right operand, described (`number 2`).
        right: String,
    },
    /// A comparison with a condition on one side.
    #[error(
        "`{op}` compares numbers or strings, not conditions (combine conditions with &&, || and !)"
    )]
    NotComparable {
        /// The comparison operator.
        op: CmpOp,
    },
    /// More than [`MAX_DEPTH`] levels of `!`, parentheses, `&&` or `||`.
    #[error(
        "the expression nests more than {MAX_DEPTH} levels deep (`!`, parentheses, `&&`, `||`)"
    )]
    TooDeep,
    /// A number or string where a condition is needed.
    #[error("{needed_by} needs a condition, found {found}{}", not_hint(.needed_by))]
    NotCondition {
        /// The operand found, described.
        found: String,
        /// Who needs the condition: "`!`", "`&&`", "`||`" or "the expression".
        needed_by: &'static str,
    },
}

/// How deeply an expression may nest: `!`, parentheses and chains of `&&` / `||` each add a
/// level. Parsing, checking and evaluating recurse once per level; the bound keeps them far
/// from the end of the stack whatever the input.
pub const MAX_DEPTH: usize = 256;

fn hint_suffix(hint: Option<&str>) -> String {
    hint.map(|h| format!(" ({h})")).unwrap_or_default()
}

fn not_hint(needed_by: &str) -> &'static str {
    if needed_by == "`!`" {
        " (`!` binds tighter than comparisons: write !(a == b))"
    } else {
        " (compare it, e.g. nrooms > 2)"
    }
}

fn column_names() -> String {
    COLUMNS
        .iter()
        .map(|(n, _)| *n)
        .collect::<Vec<_>>()
        .join(", ")
}

/// A comparison operator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CmpOp {
    /// `==`
    Eq,
    /// `!=`
    Ne,
    /// `<`
    Lt,
    /// `<=`
    Le,
    /// `>`
    Gt,
    /// `>=`
    Ge,
}

impl CmpOp {
    fn test<T: PartialOrd + ?Sized>(self, a: &T, b: &T) -> bool {
        match self {
            CmpOp::Eq => a == b,
            CmpOp::Ne => a != b,
            CmpOp::Lt => a < b,
            CmpOp::Le => a <= b,
            CmpOp::Gt => a > b,
            CmpOp::Ge => a >= b,
        }
    }
}

impl fmt::Display for CmpOp {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            CmpOp::Eq => "==",
            CmpOp::Ne => "!=",
            CmpOp::Lt => "<",
            CmpOp::Le => "<=",
            CmpOp::Gt => ">",
            CmpOp::Ge => ">=",
        })
    }
}

// ---------------------------------------------------------------------------------------------
// Columns

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum StrColumn {
    Id,
    Dataset,
    SourcePath,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum NumColumn {
    Nlevels,
    Nrooms,
    Nobjects,
    FloorArea,
    Ntriangles,
    BboxMin(Axis),
    BboxMax(Axis),
    Size(Axis),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Axis {
    X,
    Y,
    Z,
}

impl Axis {
    fn of(self, v: &[f64; 3]) -> f64 {
        match self {
            Axis::X => v[0],
            Axis::Y => v[1],
            Axis::Z => v[2],
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Column {
    Str(StrColumn),
    Num(NumColumn),
}

const COLUMNS: &[(&str, Column)] = &[
    ("id", Column::Str(StrColumn::Id)),
    ("dataset", Column::Str(StrColumn::Dataset)),
    ("source_path", Column::Str(StrColumn::SourcePath)),
    ("nlevels", Column::Num(NumColumn::Nlevels)),
    ("nrooms", Column::Num(NumColumn::Nrooms)),
    ("nobjects", Column::Num(NumColumn::Nobjects)),
    ("floor_area", Column::Num(NumColumn::FloorArea)),
    ("ntriangles", Column::Num(NumColumn::Ntriangles)),
    ("bbox_min_x", Column::Num(NumColumn::BboxMin(Axis::X))),
    ("bbox_min_y", Column::Num(NumColumn::BboxMin(Axis::Y))),
    ("bbox_min_z", Column::Num(NumColumn::BboxMin(Axis::Z))),
    ("bbox_max_x", Column::Num(NumColumn::BboxMax(Axis::X))),
    ("bbox_max_y", Column::Num(NumColumn::BboxMax(Axis::Y))),
    ("bbox_max_z", Column::Num(NumColumn::BboxMax(Axis::Z))),
    ("size_x", Column::Num(NumColumn::Size(Axis::X))),
    ("size_y", Column::Num(NumColumn::Size(Axis::Y))),
    ("size_z", Column::Num(NumColumn::Size(Axis::Z))),
];

impl StrColumn {
    fn value(self, row: &ManifestRow) -> &str {
        match self {
            StrColumn::Id => &row.id,
            StrColumn::Dataset => &row.dataset,
            StrColumn::SourcePath => &row.source_path,
        }
    }
}

impl NumColumn {
    fn value(self, row: &ManifestRow) -> f64 {
        match self {
            NumColumn::Nlevels => f64::from(row.nlevels),
            NumColumn::Nrooms => f64::from(row.nrooms),
            NumColumn::Nobjects => f64::from(row.nobjects),
            NumColumn::FloorArea => row.floor_area,
            NumColumn::Ntriangles => row.ntriangles as f64,
            NumColumn::BboxMin(a) => a.of(&row.bbox_min),
            NumColumn::BboxMax(a) => a.of(&row.bbox_max),
            NumColumn::Size(a) => a.of(&row.bbox_max) - a.of(&row.bbox_min),
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Lexer

#[derive(Debug, Clone, PartialEq)]
enum Tok {
    Num(f64),
    Str(String),
    Ident(String),
    LParen,
    RParen,
    Comma,
    Not,
    And,
    Or,
    Cmp(CmpOp),
}

impl Tok {
    fn describe(&self) -> String {
        match self {
            Tok::Num(n) => format!("number {n}"),
            Tok::Str(s) => format!("string {s:?}"),
            Tok::Ident(s) => format!("`{s}`"),
            Tok::LParen => "`(`".into(),
            Tok::RParen => "`)`".into(),
            Tok::Comma => "`,`".into(),
            Tok::Not => "`!`".into(),
            Tok::And => "`&&`".into(),
            Tok::Or => "`||`".into(),
            Tok::Cmp(op) => format!("`{op}`"),
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
struct Token {
    tok: Tok,
    col: usize,
}

fn lex(source: &str) -> Result<Vec<Token>, ExprError> {
    let chars: Vec<char> = source.chars().collect();
    let mut tokens = Vec::new();
    let mut i = 0;
    while let Some(&c) = chars.get(i) {
        let col = i + 1;
        let next = chars.get(i + 1).copied();
        let two = |tok: Tok| (tok, 2);
        let (tok, len) = match (c, next) {
            (c, _) if c.is_whitespace() => {
                i += 1;
                continue;
            }
            ('(', _) => (Tok::LParen, 1),
            (')', _) => (Tok::RParen, 1),
            (',', _) => (Tok::Comma, 1),
            ('&', Some('&')) => two(Tok::And),
            ('|', Some('|')) => two(Tok::Or),
            ('=', Some('=')) => two(Tok::Cmp(CmpOp::Eq)),
            ('!', Some('=')) => two(Tok::Cmp(CmpOp::Ne)),
            ('<', Some('=')) => two(Tok::Cmp(CmpOp::Le)),
            ('>', Some('=')) => two(Tok::Cmp(CmpOp::Ge)),
            ('!', _) => (Tok::Not, 1),
            ('<', _) => (Tok::Cmp(CmpOp::Lt), 1),
            ('>', _) => (Tok::Cmp(CmpOp::Gt), 1),
            ('"', _) => lex_string(&chars, i)?,
            (c, _) if c.is_ascii_digit() => lex_number(&chars, i)?,
            ('-' | '.', Some(d)) if d.is_ascii_digit() => lex_number(&chars, i)?,
            (c, _) if c.is_alphabetic() || c == '_' => {
                let len = chars[i..]
                    .iter()
                    .take_while(|c| c.is_alphanumeric() || **c == '_')
                    .count();
                (Tok::Ident(chars[i..i + len].iter().collect()), len)
            }
            (found, _) => {
                let hint = match found {
                    '=' => Some("did you mean `==`?"),
                    '&' => Some("did you mean `&&`?"),
                    '|' => Some("did you mean `||`?"),
                    '\'' | '\u{2018}' | '\u{2019}' | '\u{201c}' | '\u{201d}' => {
                        Some("strings use plain double quotes: \"…\"")
                    }
                    _ => None,
                };
                return Err(ExprError::new(
                    col,
                    ExprErrorKind::UnexpectedChar { found, hint },
                ));
            }
        };
        tokens.push(Token { tok, col });
        i += len;
    }
    Ok(tokens)
}

/// A string literal starting at the quote `chars[start]`: the token and its length in chars.
fn lex_string(chars: &[char], start: usize) -> Result<(Tok, usize), ExprError> {
    let mut text = String::new();
    let mut i = start + 1;
    loop {
        match chars.get(i) {
            None => return Err(ExprError::new(start + 1, ExprErrorKind::UnterminatedString)),
            Some('"') => return Ok((Tok::Str(text), i + 1 - start)),
            Some('\\') => match chars.get(i + 1) {
                Some(&c @ ('"' | '\\')) => {
                    text.push(c);
                    i += 2;
                }
                Some(&c) => return Err(ExprError::new(i + 1, ExprErrorKind::BadEscape(c))),
                None => return Err(ExprError::new(start + 1, ExprErrorKind::UnterminatedString)),
            },
            Some(&c) => {
                text.push(c);
                i += 1;
            }
        }
    }
}

/// A number literal (optionally negative) starting at `chars[start]`. The token runs over every
/// character a number or an identifier could hold, so `2abc` is one bad number, not two tokens.
fn lex_number(chars: &[char], start: usize) -> Result<(Tok, usize), ExprError> {
    let mut i = start + usize::from(chars[start] == '-');
    while let Some(&c) = chars.get(i) {
        let exponent_sign =
            matches!(c, '+' | '-') && matches!(chars.get(i.wrapping_sub(1)), Some('e' | 'E'));
        if c.is_alphanumeric() || c == '_' || c == '.' || exponent_sign {
            i += 1;
        } else {
            break;
        }
    }
    let text: String = chars[start..i].iter().collect();
    match text.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok((Tok::Num(v), i - start)),
        _ => Err(ExprError::new(start + 1, ExprErrorKind::BadNumber(text))),
    }
}

// ---------------------------------------------------------------------------------------------
// Parser: tokens to an untyped tree with names resolved

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Function {
    HasRoom,
    HasCategory,
}

impl Function {
    fn from_name(name: &str) -> Option<Function> {
        match name {
            "has_room" => Some(Function::HasRoom),
            "has_category" => Some(Function::HasCategory),
            _ => None,
        }
    }

    fn name(self) -> &'static str {
        match self {
            Function::HasRoom => "has_room",
            Function::HasCategory => "has_category",
        }
    }

    fn bad_argument(self) -> ExprErrorKind {
        ExprErrorKind::BadArgument {
            function: self.name(),
            example: match self {
                Function::HasRoom => "kitchen",
                Function::HasCategory => "door",
            },
        }
    }
}

/// A node of the untyped tree; `col` is where its error, if any, is reported: the start of a
/// leaf, the operator of an operation.
#[derive(Debug, Clone, PartialEq)]
struct Node {
    col: usize,
    kind: NodeKind,
    /// Levels of nodes from this one down to its deepest leaf (a leaf: 1).
    depth: usize,
}

#[derive(Debug, Clone, PartialEq)]
enum NodeKind {
    Num(f64),
    Str(String),
    Column(&'static str, Column),
    Call(Function, String),
    Not(Box<Node>),
    Cmp(CmpOp, Box<Node>, Box<Node>),
    And(Box<Node>, Box<Node>),
    Or(Box<Node>, Box<Node>),
}

impl Node {
    /// A node over its children; more than [`MAX_DEPTH`] levels is an error at `col`.
    fn new(col: usize, kind: NodeKind) -> Result<Node, ExprError> {
        let depth = 1 + match &kind {
            NodeKind::Not(a) => a.depth,
            NodeKind::Cmp(_, a, b) | NodeKind::And(a, b) | NodeKind::Or(a, b) => {
                a.depth.max(b.depth)
            }
            _ => 0,
        };
        if depth > MAX_DEPTH {
            return Err(ExprError::new(col, ExprErrorKind::TooDeep));
        }
        Ok(Node { col, kind, depth })
    }

    /// The operand as error messages name it.
    fn describe(&self) -> String {
        match &self.kind {
            NodeKind::Num(n) => format!("number {n}"),
            NodeKind::Str(s) => format!("string {s:?}"),
            NodeKind::Column(name, Column::Num(_)) => format!("number column `{name}`"),
            NodeKind::Column(name, Column::Str(_)) => format!("string column `{name}`"),
            _ => "a condition".into(),
        }
    }
}

struct Parser {
    tokens: Vec<Token>,
    pos: usize,
    /// `!` and `(` being parsed around the current position (bounded by [`MAX_DEPTH`]).
    open: usize,
    /// Column just past the last character, where "end of expression" errors point.
    end: usize,
}

impl Parser {
    fn peek(&self) -> Option<&Token> {
        self.tokens.get(self.pos)
    }

    fn next(&mut self, expected: &'static str) -> Result<Token, ExprError> {
        match self.tokens.get(self.pos) {
            Some(t) => {
                self.pos += 1;
                Ok(t.clone())
            }
            None => Err(ExprError::new(
                self.end,
                ExprErrorKind::Unexpected {
                    found: "the end of the expression".into(),
                    expected,
                },
            )),
        }
    }

    /// Consumes the next token when `accept` takes it.
    fn eat<T>(&mut self, accept: impl Fn(&Tok) -> Option<T>) -> Option<(T, usize)> {
        let t = self.peek()?;
        let v = accept(&t.tok)?;
        let col = t.col;
        self.pos += 1;
        Some((v, col))
    }

    /// Parses with `parse` one level deeper (after a `!` or `(` at `col`).
    fn nested(
        &mut self,
        col: usize,
        parse: fn(&mut Parser) -> Result<Node, ExprError>,
    ) -> Result<Node, ExprError> {
        if self.open >= MAX_DEPTH {
            return Err(ExprError::new(col, ExprErrorKind::TooDeep));
        }
        self.open += 1;
        let node = parse(self);
        self.open -= 1;
        node
    }

    fn or(&mut self) -> Result<Node, ExprError> {
        let mut left = self.and()?;
        while let Some(((), col)) = self.eat(|t| (*t == Tok::Or).then_some(())) {
            let right = self.and()?;
            left = Node::new(col, NodeKind::Or(Box::new(left), Box::new(right)))?;
        }
        Ok(left)
    }

    fn and(&mut self) -> Result<Node, ExprError> {
        let mut left = self.cmp()?;
        while let Some(((), col)) = self.eat(|t| (*t == Tok::And).then_some(())) {
            let right = self.cmp()?;
            left = Node::new(col, NodeKind::And(Box::new(left), Box::new(right)))?;
        }
        Ok(left)
    }

    fn cmp(&mut self) -> Result<Node, ExprError> {
        let left = self.unary()?;
        let cmp_op = |t: &Tok| match t {
            Tok::Cmp(op) => Some(*op),
            _ => None,
        };
        let Some((op, col)) = self.eat(cmp_op) else {
            return Ok(left);
        };
        let right = self.unary()?;
        if let Some(t) = self.peek().filter(|t| cmp_op(&t.tok).is_some()) {
            return Err(ExprError::new(t.col, ExprErrorKind::ChainedComparison));
        }
        Node::new(col, NodeKind::Cmp(op, Box::new(left), Box::new(right)))
    }

    fn unary(&mut self) -> Result<Node, ExprError> {
        if let Some(((), col)) = self.eat(|t| (*t == Tok::Not).then_some(())) {
            let inner = self.nested(col, Parser::unary)?;
            return Node::new(col, NodeKind::Not(Box::new(inner)));
        }
        self.primary()
    }

    fn primary(&mut self) -> Result<Node, ExprError> {
        const OPERAND: &str = "a number, a string, a column, a function, `!` or `(`";
        let Token { tok, col } = self.next(OPERAND)?;
        let kind = match tok {
            Tok::Num(n) => NodeKind::Num(n),
            Tok::Str(s) => NodeKind::Str(s),
            Tok::LParen => {
                let inner = self.nested(col, Parser::or)?;
                let close = self.next("`)`")?;
                if close.tok != Tok::RParen {
                    let kind = ExprErrorKind::Unexpected {
                        found: close.tok.describe(),
                        expected: "`)`",
                    };
                    return Err(ExprError::new(close.col, kind));
                }
                return Ok(inner);
            }
            Tok::Ident(name) => return self.name(name, col),
            other => {
                return Err(ExprError::new(
                    col,
                    ExprErrorKind::Unexpected {
                        found: other.describe(),
                        expected: OPERAND,
                    },
                ))
            }
        };
        Node::new(col, kind)
    }

    /// A column, or a function call when `(` follows.
    fn name(&mut self, name: String, col: usize) -> Result<Node, ExprError> {
        let called = self.peek().is_some_and(|t| t.tok == Tok::LParen);
        if called {
            let function = Function::from_name(&name)
                .ok_or_else(|| ExprError::new(col, ExprErrorKind::UnknownFunction { name }))?;
            self.pos += 1;
            let bad = |c: usize| ExprError::new(c, function.bad_argument());
            let arg = self.next("a string").map_err(|e| bad(e.column))?;
            let Tok::Str(text) = arg.tok else {
                return Err(bad(arg.col));
            };
            let close = self.next("`)`").map_err(|e| bad(e.column))?;
            if close.tok != Tok::RParen {
                return Err(bad(close.col));
            }
            return Node::new(col, NodeKind::Call(function, text));
        }
        if let Some(function) = Function::from_name(&name) {
            return Err(ExprError::new(col, function.bad_argument()));
        }
        match COLUMNS.iter().find(|(n, _)| *n == name) {
            Some(&(n, column)) => Node::new(col, NodeKind::Column(n, column)),
            None => Err(ExprError::new(col, ExprErrorKind::UnknownColumn { name })),
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Check: the untyped tree to the typed one

/// A boolean node of the typed tree.
#[derive(Debug, Clone, PartialEq)]
enum Cond {
    Or(Box<Cond>, Box<Cond>),
    And(Box<Cond>, Box<Cond>),
    Not(Box<Cond>),
    Num(NumTerm, CmpOp, NumTerm),
    Str(StrTerm, CmpOp, StrTerm),
    /// `has_room(name)`: `class` is `name` read as a MINOS class, when it is one.
    HasRoom {
        name: String,
        class: Option<RoomClass>,
    },
    HasCategory(String),
}

#[derive(Debug, Clone, PartialEq)]
enum NumTerm {
    Lit(f64),
    Col(NumColumn),
}

#[derive(Debug, Clone, PartialEq)]
enum StrTerm {
    Lit(String),
    Col(StrColumn),
}

/// A typed node: a condition, or an operand of a comparison.
enum Typed {
    Cond(Cond),
    Num(NumTerm),
    Str(StrTerm),
}

fn check(node: &Node) -> Result<Typed, ExprError> {
    let both = |l: &Node, r: &Node, by: &'static str| -> Result<_, ExprError> {
        Ok((Box::new(check_cond(l, by)?), Box::new(check_cond(r, by)?)))
    };
    let typed = match &node.kind {
        NodeKind::Num(n) => Typed::Num(NumTerm::Lit(*n)),
        NodeKind::Str(s) => Typed::Str(StrTerm::Lit(s.clone())),
        NodeKind::Column(_, Column::Num(c)) => Typed::Num(NumTerm::Col(*c)),
        NodeKind::Column(_, Column::Str(c)) => Typed::Str(StrTerm::Col(*c)),
        NodeKind::Call(Function::HasRoom, name) => Typed::Cond(Cond::HasRoom {
            name: name.clone(),
            class: RoomClass::from_label(name),
        }),
        NodeKind::Call(Function::HasCategory, name) => Typed::Cond(Cond::HasCategory(name.clone())),
        NodeKind::Not(inner) => Typed::Cond(Cond::Not(Box::new(check_cond(inner, "`!`")?))),
        NodeKind::And(l, r) => {
            let (l, r) = both(l, r, "`&&`")?;
            Typed::Cond(Cond::And(l, r))
        }
        NodeKind::Or(l, r) => {
            let (l, r) = both(l, r, "`||`")?;
            Typed::Cond(Cond::Or(l, r))
        }
        NodeKind::Cmp(op, l, r) => match (check(l)?, check(r)?) {
            (Typed::Num(a), Typed::Num(b)) => Typed::Cond(Cond::Num(a, *op, b)),
            (Typed::Str(a), Typed::Str(b)) => Typed::Cond(Cond::Str(a, *op, b)),
            (Typed::Cond(_), _) | (_, Typed::Cond(_)) => {
                return Err(ExprError::new(
                    node.col,
                    ExprErrorKind::NotComparable { op: *op },
                ))
            }
            _ => {
                return Err(ExprError::new(
                    node.col,
                    ExprErrorKind::Mismatch {
                        left: l.describe(),
                        right: r.describe(),
                    },
                ))
            }
        },
    };
    Ok(typed)
}

fn check_cond(node: &Node, needed_by: &'static str) -> Result<Cond, ExprError> {
    match check(node)? {
        Typed::Cond(c) => Ok(c),
        Typed::Num(_) | Typed::Str(_) => Err(ExprError::new(
            node.col,
            ExprErrorKind::NotCondition {
                found: node.describe(),
                needed_by,
            },
        )),
    }
}

// ---------------------------------------------------------------------------------------------
// Evaluation

/// Unicode case-insensitive equality, without allocating.
fn eq_ignore_case(a: &str, b: &str) -> bool {
    a.chars()
        .flat_map(char::to_lowercase)
        .eq(b.chars().flat_map(char::to_lowercase))
}

impl NumTerm {
    fn value(&self, row: &ManifestRow) -> f64 {
        match self {
            NumTerm::Lit(v) => *v,
            NumTerm::Col(c) => c.value(row),
        }
    }
}

impl StrTerm {
    fn value<'a>(&'a self, row: &'a ManifestRow) -> &'a str {
        match self {
            StrTerm::Lit(s) => s,
            StrTerm::Col(c) => c.value(row),
        }
    }
}

impl Cond {
    fn eval(&self, row: &ManifestRow) -> bool {
        match self {
            Cond::Or(a, b) => a.eval(row) || b.eval(row),
            Cond::And(a, b) => a.eval(row) && b.eval(row),
            Cond::Not(a) => !a.eval(row),
            Cond::Num(a, op, b) => op.test(&a.value(row), &b.value(row)),
            Cond::Str(a, op, b) => op.test(a.value(row), b.value(row)),
            Cond::HasRoom { name, class } => {
                let by_class = class.is_some_and(|c| {
                    row.room_classes
                        .iter()
                        .any(|n| RoomClass::from_label(n) == Some(c))
                });
                by_class || row.room_types.iter().any(|t| eq_ignore_case(t, name))
            }
            Cond::HasCategory(name) => row
                .categories
                .iter()
                .chain(&row.coarse_categories)
                .any(|c| eq_ignore_case(c, name)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row() -> ManifestRow {
        ManifestRow {
            id: "h1".into(),
            dataset: "suncg".into(),
            source_path: "house/h1/house.json".into(),
            nlevels: 1,
            nrooms: 4,
            nobjects: 30,
            floor_area: 50.5,
            bbox_min: [-1.0, 0.0, 2.0],
            bbox_max: [9.0, 2.5, 8.0],
            room_classes: vec!["bedroom".into(), "kitchen".into(), "living_room".into()],
            room_types: vec!["Bedroom".into(), "Garage".into(), "Kitchen".into()],
            categories: vec!["chair".into(), "double_bed".into()],
            coarse_categories: vec!["Door".into(), "bed".into()],
            ntriangles: 12_345,
            error: None,
        }
    }

    fn eval(src: &str, r: &ManifestRow) -> bool {
        Expr::parse(src)
            .unwrap_or_else(|e| panic!("{src}: {e}"))
            .matches(r)
    }

    fn err(src: &str) -> ExprError {
        match Expr::parse(src) {
            Ok(e) => panic!("{src} parsed as {e:?}"),
            Err(e) => e,
        }
    }

    #[test]
    fn every_comparison_operator_on_numbers() {
        let r = row(); // nrooms = 4
        let cases = [
            ("nrooms == 4", true),
            ("nrooms == 3", false),
            ("nrooms != 3", true),
            ("nrooms != 4", false),
            ("nrooms < 5", true),
            ("nrooms < 4", false),
            ("nrooms <= 4", true),
            ("nrooms <= 3", false),
            ("nrooms > 3", true),
            ("nrooms > 4", false),
            ("nrooms >= 4", true),
            ("nrooms >= 5", false),
            ("4 == nrooms", true),
            ("floor_area >= 50.5", true),
            ("floor_area > 50.5", false),
            ("bbox_min_x > -1.5", true),
            ("bbox_min_x < -1", false),
            ("ntriangles == 1.2345e4", true),
            ("1 < 2", true),
        ];
        for (src, want) in cases {
            assert_eq!(eval(src, &r), want, "{src}");
        }
    }

    #[test]
    fn string_comparisons_are_exact_and_ordered() {
        let r = row();
        assert!(eval(r#"dataset == "suncg""#, &r));
        assert!(!eval(r#"dataset == "SUNCG""#, &r));
        assert!(eval(r#"dataset != "mp3d""#, &r));
        assert!(eval(r#"id < "h2" && id >= "h1""#, &r));
        assert!(!eval(r#"id > "h1""#, &r));
        assert!(eval(r#"source_path == "house/h1/house.json""#, &r));
        assert!(eval(r#""a\"b\\" == "a\"b\\""#, &r));
    }

    #[test]
    fn every_column_reads_its_field() {
        let r = row();
        let cases = [
            ("nlevels == 1", true),
            ("nobjects == 30", true),
            ("bbox_min_y == 0", true),
            ("bbox_min_z == 2", true),
            ("bbox_max_x == 9", true),
            ("bbox_max_y == 2.5", true),
            ("bbox_max_z == 8", true),
            ("size_x == 10", true),
            ("size_y == 2.5", true),
            ("size_z == 6", true),
        ];
        for (src, want) in cases {
            assert_eq!(eval(src, &r), want, "{src}");
        }
        // Every column is documented in the help text.
        for (name, _) in COLUMNS {
            assert!(
                SYNTAX_HELP.contains(name),
                "{name} missing from SYNTAX_HELP"
            );
        }
    }

    #[test]
    fn logic_operators_and_precedence() {
        let r = row();
        assert!(eval("nrooms == 4 && nlevels == 1", &r));
        assert!(!eval("nrooms == 4 && nlevels == 2", &r));
        assert!(eval("nrooms == 9 || nlevels == 1", &r));
        assert!(!eval("nrooms == 9 || nlevels == 2", &r));
        assert!(eval("!(nrooms == 9)", &r));
        assert!(!eval("!(nrooms == 4)", &r));
        assert!(eval("!!(nrooms == 4)", &r));
        // && binds tighter than ||: true || (false && false) is true; (true || false) && false
        // would be false.
        assert!(eval("nrooms == 4 || nrooms == 9 && nlevels == 9", &r));
        assert!(!eval("(nrooms == 4 || nrooms == 9) && nlevels == 9", &r));
        // false && false || true: && first gives true; || first would give false.
        assert!(eval("nrooms == 9 && nlevels == 9 || nobjects == 30", &r));
        // ! binds tighter than &&: (!false) && true.
        assert!(eval("!has_room(\"office\") && nrooms == 4", &r));
        assert!(!eval("!has_room(\"kitchen\") || nrooms == 9", &r));
    }

    #[test]
    fn precedence_shapes_the_tree() {
        // a || b && c parses as a || (b && c).
        let e = Expr::parse("nrooms == 1 || nrooms == 2 && nrooms == 3").unwrap();
        assert!(matches!(&e.root, Cond::Or(_, b) if matches!(**b, Cond::And(..))));
        // !a && b parses as (!a) && b.
        let e = Expr::parse("!has_room(\"x\") && nrooms == 3").unwrap();
        assert!(matches!(&e.root, Cond::And(a, _) if matches!(**a, Cond::Not(_))));
    }

    #[test]
    fn minos_examples() {
        let mut r = row();
        r.nrooms = 2;
        assert!(eval("nrooms == 2", &r));
        assert!(!eval("nrooms > 2 && nrooms < 6", &r));
        r.nrooms = 5;
        assert!(eval("nrooms > 2 && nrooms < 6", &r));
        r.nrooms = 6;
        assert!(!eval("nrooms > 2 && nrooms < 6", &r));

        let kitchen_no_person = r#"has_room("kitchen") && !has_category("person")"#;
        assert!(eval(kitchen_no_person, &r));
        r.categories.push("person".into());
        assert!(!eval(kitchen_no_person, &r));

        let either = r#"dataset == "suncg" || floor_area >= 50.5"#;
        assert!(eval(either, &r));
        r.dataset = "mp3d".into();
        assert!(eval(either, &r));
        r.floor_area = 50.4;
        assert!(!eval(either, &r));
    }

    #[test]
    fn has_room_uses_classes_aliases_and_raw_types() {
        let r = row();
        assert!(eval(r#"has_room("kitchen")"#, &r));
        assert!(eval(r#"has_room("lounge")"#, &r), "alias of living_room");
        assert!(eval(r#"has_room("Living_Room")"#, &r));
        assert!(!eval(r#"has_room("bathroom")"#, &r));
        assert!(
            !eval(r#"has_room("toilet")"#, &r),
            "alias of an absent class"
        );
        assert!(eval(r#"has_room("garage")"#, &r), "raw type, any case");
        assert!(!eval(r#"has_room("garag")"#, &r));
    }

    #[test]
    fn has_category_checks_fine_and_coarse_any_case() {
        let r = row();
        assert!(eval(r#"has_category("chair")"#, &r));
        assert!(eval(r#"has_category("CHAIR")"#, &r));
        assert!(eval(r#"has_category("door")"#, &r), "coarse, other case");
        assert!(eval(r#"has_category("bed")"#, &r));
        assert!(!eval(r#"has_category("person")"#, &r));
    }

    #[test]
    fn whitespace_is_free_and_source_is_kept() {
        let r = row();
        assert!(eval("(nrooms==4)&&!(nlevels>1)", &r));
        assert!(eval("  nrooms\t==\n4  ", &r));
        assert_eq!(Expr::parse("nrooms==4").unwrap().to_string(), "nrooms==4");
    }

    #[test]
    fn lexical_errors_have_their_column() {
        let cases: [(&str, usize, ExprErrorKind); 7] = [
            (
                "nrooms = 2",
                8,
                ExprErrorKind::UnexpectedChar {
                    found: '=',
                    hint: Some("did you mean `==`?"),
                },
            ),
            (
                "a & b",
                3,
                ExprErrorKind::UnexpectedChar {
                    found: '&',
                    hint: Some("did you mean `&&`?"),
                },
            ),
            (
                "nrooms # 2",
                8,
                ExprErrorKind::UnexpectedChar {
                    found: '#',
                    hint: None,
                },
            ),
            ("id == \"abc", 7, ExprErrorKind::UnterminatedString),
            ("id == \"a\\nb\"", 9, ExprErrorKind::BadEscape('n')),
            ("nrooms > 2abc", 10, ExprErrorKind::BadNumber("2abc".into())),
            (
                "nrooms > 1e999",
                10,
                ExprErrorKind::BadNumber("1e999".into()),
            ),
        ];
        for (src, column, kind) in cases {
            assert_eq!(err(src), ExprError { column, kind }, "{src}");
        }
        // Columns count characters, not bytes.
        assert_eq!(err("id == \"é\" & x").column, 11);
    }

    #[test]
    fn syntax_errors_have_their_column() {
        assert_eq!(err("   ").kind, ExprErrorKind::Empty);
        let e = err("nrooms ==");
        assert_eq!(e.column, 10);
        assert!(
            matches!(e.kind, ExprErrorKind::Unexpected { ref found, .. } if found == "the end of the expression")
        );
        let e = err("(nrooms == 2");
        assert_eq!(e.column, 13);
        assert!(matches!(
            e.kind,
            ExprErrorKind::Unexpected {
                expected: "`)`",
                ..
            }
        ));
        let e = err("nrooms == 2)");
        assert_eq!(e.column, 12);
        assert!(matches!(e.kind, ExprErrorKind::Unexpected { ref found, .. } if found == "`)`"));
        let e = err("nrooms == 2 nlevels");
        assert_eq!(e.column, 13);
        assert!(matches!(e.kind, ExprErrorKind::Unexpected { .. }));
        let e = err("&& nrooms");
        assert_eq!(
            (e.column, e.kind.to_string().contains("found `&&`")),
            (1, true)
        );
        assert_eq!(
            err("1 < nrooms < 6"),
            ExprError::new(12, ExprErrorKind::ChainedComparison)
        );
        assert_eq!(
            err("(1 < nrooms < 6)"),
            ExprError::new(13, ExprErrorKind::ChainedComparison)
        );
    }

    #[test]
    fn name_errors_have_their_column() {
        let e = err("nrooms > 2 && nroom < 6");
        assert_eq!(e.column, 15);
        assert_eq!(
            e.kind,
            ExprErrorKind::UnknownColumn {
                name: "nroom".into()
            }
        );
        let msg = e.to_string();
        assert!(msg.starts_with("at column 15: unknown column `nroom` (known: id, dataset,"));
        assert!(msg.contains("size_z)"), "{msg}");

        assert_eq!(
            err("has_rooms(\"x\")"),
            ExprError::new(
                1,
                ExprErrorKind::UnknownFunction {
                    name: "has_rooms".into()
                }
            )
        );
        let bad_room = Function::HasRoom.bad_argument();
        assert_eq!(
            err("has_room(kitchen)"),
            ExprError::new(10, bad_room.clone())
        );
        assert_eq!(err("has_room()"), ExprError::new(10, bad_room.clone()));
        assert_eq!(
            err("has_room(\"a\", \"b\")"),
            ExprError::new(13, bad_room.clone())
        );
        assert_eq!(err("has_room(\"a\""), ExprError::new(13, bad_room.clone()));
        assert_eq!(
            err("x || has_room"),
            ExprError::new(1, ExprErrorKind::UnknownColumn { name: "x".into() })
        );
        assert_eq!(err("nrooms > 1 || has_room"), ExprError::new(15, bad_room));
    }

    #[test]
    fn type_errors_are_found_before_evaluation() {
        let e = err("dataset == 2");
        assert_eq!(e.column, 9);
        assert_eq!(
            e.to_string(),
            "at column 9: cannot compare string column `dataset` with number 2"
        );
        let e = err("nrooms > 2 && nrooms < \"6\"");
        assert_eq!(e.column, 22);
        assert!(matches!(e.kind, ExprErrorKind::Mismatch { .. }));

        let e = err("has_room(\"a\") == 1");
        assert_eq!(
            e,
            ExprError::new(15, ExprErrorKind::NotComparable { op: CmpOp::Eq })
        );

        let e = err("nrooms");
        assert_eq!(e.column, 1);
        assert!(matches!(
            e.kind,
            ExprErrorKind::NotCondition {
                needed_by: "the expression",
                ..
            }
        ));
        // `!` binds tighter than `==`, so this negates a number.
        let e = err("!nrooms == 2");
        assert_eq!(e.column, 2);
        assert!(e.to_string().contains("write !(a == b)"), "{e}");
        let e = err("nrooms == 2 && \"x\"");
        assert_eq!(e.column, 16);
        assert!(matches!(
            e.kind,
            ExprErrorKind::NotCondition {
                needed_by: "`&&`",
                ..
            }
        ));
        let e = err("3 || nrooms == 2");
        assert_eq!(e.column, 1);
        assert!(matches!(
            e.kind,
            ExprErrorKind::NotCondition {
                needed_by: "`||`",
                ..
            }
        ));
    }

    #[test]
    fn nesting_deeper_than_the_bound_is_an_error_not_a_stack_overflow() {
        let too_deep = |source: &str| {
            let e = Expr::parse(source).expect_err("refused");
            assert_eq!(e.kind, ExprErrorKind::TooDeep, "{e}");
            e.column
        };
        let bangs = |n: usize| format!("{}has_category(\"door\")", "!".repeat(n));
        assert_eq!(too_deep(&bangs(30_000)), MAX_DEPTH + 1);
        let parens = format!("{}nrooms > 1{}", "(".repeat(50_000), ")".repeat(50_000));
        assert_eq!(too_deep(&parens), MAX_DEPTH + 1);
        // A left-nested chain of `||` is as deep as it is long.
        too_deep(&vec!["nrooms > 1"; 50_000].join(" || "));
        too_deep(&vec!["nrooms > 1"; 50_000].join(" && "));
        // `!` × k over a call is k + 1 levels: the deepest accepted has k = 255, and it
        // still evaluates (an odd number of `!`: the negated call).
        let e = Expr::parse(&bangs(MAX_DEPTH - 1)).unwrap();
        let once = Expr::parse("!has_category(\"door\")").unwrap();
        assert_eq!(e.matches(&row()), once.matches(&row()));
        too_deep(&bangs(MAX_DEPTH));
        assert!(Expr::parse(&format!("{}nrooms > 1{}", "(".repeat(200), ")".repeat(200))).is_ok());
    }
}
