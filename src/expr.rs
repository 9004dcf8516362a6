//! A small compiler for the math expressions written in case files.
//!
//! An expression such as `0.1*sin(2*pi*x) + y^2` is parsed once against a
//! list of variable names and compiled to a flat stack program with
//! constants folded. Evaluation walks that program with a fixed-size stack
//! on the machine stack, so [`Expr::eval`] never allocates: it is meant to be
//! called millions of times. [`Expr::eval_gradient`] walks the same program
//! in forward mode (dual numbers), giving the value and the exact partial
//! derivatives in one pass, as Newton's methods on an expression need.
//!
//! Grammar (lowest to highest precedence):
//!
//! ```text
//! expr    := term (('+' | '-') term)*
//! term    := unary (('*' | '/') unary)*
//! unary   := ('-' | '+') unary | power
//! power   := primary ('^' unary)?          right-associative
//! primary := number | name | name '(' expr (',' expr)* ')' | '(' expr ')'
//! ```
//!
//! so `-x^2` is `-(x^2)`, `2^3^2` is `2^(3^2)` and `2^-1` is `0.5`.
//! Names are variables (which shadow the constants), the constants `pi` and
//! `e`, or the functions listed in [`Expr::FUNCTIONS`].

use std::fmt;

/// Maximum operand-stack depth of a compiled expression. Deeper expressions
/// are rejected at parse time so evaluation can use a fixed array.
const MAX_STACK: usize = 64;

/// Stack depth that nearly every expression fits: evaluated with an array
/// of this size, which is cheaper to set up than one of [`MAX_STACK`].
const SHORT_STACK: usize = 8;

/// Maximum nesting of parentheses, calls and unary operators, so that
/// hostile input cannot overflow the parser's recursion.
const MAX_NESTING: usize = 200;

/// Why an expression could not be compiled. Columns count characters from 1.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ExprError {
    /// The parser needed one thing and found another.
    #[error("expected {expected} at column {column}, found {found}")]
    Expected {
        /// What would have been valid here, e.g. "`)`".
        expected: String,
        /// What was there instead, e.g. "end of input".
        found: String,
        /// Character column (1-based).
        column: usize,
    },
    /// A character that starts no token.
    #[error("unexpected character `{ch}` at column {column}")]
    UnexpectedChar {
        /// The offending character.
        ch: char,
        /// Character column (1-based).
        column: usize,
    },
    /// A malformed number literal such as `1e` or `1.2.3`.
    #[error("invalid number `{text}` at column {column}")]
    InvalidNumber {
        /// The literal as written.
        text: String,
        /// Character column (1-based).
        column: usize,
    },
    /// A name that is neither a variable nor a constant.
    #[error("unknown variable `{name}` at column {column} (known: {known})")]
    UnknownVariable {
        /// The name as written.
        name: String,
        /// Character column (1-based).
        column: usize,
        /// Comma-separated variable and constant names that are allowed.
        known: String,
    },
    /// A call of a function that does not exist.
    #[error("unknown function `{name}` at column {column} (known: {known})")]
    UnknownFunction {
        /// The name as written.
        name: String,
        /// Character column (1-based).
        column: usize,
        /// Comma-separated function names.
        known: String,
    },
    /// A known function called with the wrong number of arguments.
    #[error("function `{name}` at column {column} takes {expected} argument(s), got {got}")]
    ArgumentCount {
        /// The function name.
        name: String,
        /// Character column (1-based) of the function name.
        column: usize,
        /// "1", "2" or "at least 1".
        expected: String,
        /// Number of arguments given.
        got: usize,
    },
    /// The expression nests too deeply to be evaluated with a fixed stack.
    #[error("expression too deeply nested at column {column}")]
    TooDeep {
        /// Character column (1-based) where the limit was exceeded.
        column: usize,
    },
}

/// One-argument functions.
#[derive(Debug, Clone, Copy, PartialEq)]
enum F1 {
    Sin,
    Cos,
    Tan,
    Asin,
    Acos,
    Atan,
    Sinh,
    Cosh,
    Tanh,
    Exp,
    Ln,
    Log10,
    Sqrt,
    Abs,
    Floor,
    Ceil,
    Sign,
}

impl F1 {
    /// The derivative f'(x), given `v = f(x)` (which several reuse).
    /// Where f is not differentiable: `abs'(0) = 0` (the mean of the
    /// one-sided slopes, what a central difference gives) and the
    /// derivatives of the step functions `floor`, `ceil`, `sign` are 0.
    fn derivative(self, x: f64, v: f64) -> f64 {
        match self {
            F1::Sin => x.cos(),
            F1::Cos => -x.sin(),
            F1::Tan => 1.0 + v * v,
            F1::Asin => 1.0 / (1.0 - x * x).sqrt(),
            F1::Acos => -1.0 / (1.0 - x * x).sqrt(),
            F1::Atan => 1.0 / (1.0 + x * x),
            F1::Sinh => x.cosh(),
            F1::Cosh => x.sinh(),
            F1::Tanh => 1.0 - v * v,
            F1::Exp => v,
            F1::Ln => 1.0 / x,
            F1::Log10 => 1.0 / (x * std::f64::consts::LN_10),
            F1::Sqrt => 0.5 / v,
            F1::Abs => sign(x),
            F1::Floor | F1::Ceil | F1::Sign => 0.0,
        }
    }

    fn apply(self, x: f64) -> f64 {
        match self {
            F1::Sin => x.sin(),
            F1::Cos => x.cos(),
            F1::Tan => x.tan(),
            F1::Asin => x.asin(),
            F1::Acos => x.acos(),
            F1::Atan => x.atan(),
            F1::Sinh => x.sinh(),
            F1::Cosh => x.cosh(),
            F1::Tanh => x.tanh(),
            F1::Exp => x.exp(),
            F1::Ln => x.ln(),
            F1::Log10 => x.log10(),
            F1::Sqrt => x.sqrt(),
            F1::Abs => x.abs(),
            F1::Floor => x.floor(),
            F1::Ceil => x.ceil(),
            F1::Sign => sign(x),
        }
    }
}

/// `sign(0) = 0`, unlike `f64::signum`, which is what users of a math
/// expression expect; NaN stays NaN.
fn sign(x: f64) -> f64 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        x * 0.0
    }
}

/// Two-operand operations (binary operators and two-argument functions).
#[derive(Debug, Clone, Copy, PartialEq)]
enum F2 {
    Add,
    Sub,
    Mul,
    Div,
    Pow,
    Atan2,
    Min,
    Max,
}

impl F2 {
    fn apply(self, a: f64, b: f64) -> f64 {
        match self {
            F2::Add => a + b,
            F2::Sub => a - b,
            F2::Mul => a * b,
            F2::Div => a / b,
            F2::Pow => a.powf(b),
            F2::Atan2 => a.atan2(b),
            F2::Min => a.min(b),
            F2::Max => a.max(b),
        }
    }
}

/// How many arguments a function accepts.
#[derive(Debug, Clone, Copy)]
enum Arity {
    One(F1),
    Two(F2),
    /// `min`/`max`: one or more, folded pairwise.
    Many(F2),
}

/// The function table: name → operation.
const FUNCTIONS: &[(&str, Arity)] = &[
    ("sin", Arity::One(F1::Sin)),
    ("cos", Arity::One(F1::Cos)),
    ("tan", Arity::One(F1::Tan)),
    ("asin", Arity::One(F1::Asin)),
    ("acos", Arity::One(F1::Acos)),
    ("atan", Arity::One(F1::Atan)),
    ("atan2", Arity::Two(F2::Atan2)),
    ("sinh", Arity::One(F1::Sinh)),
    ("cosh", Arity::One(F1::Cosh)),
    ("tanh", Arity::One(F1::Tanh)),
    ("exp", Arity::One(F1::Exp)),
    ("log", Arity::One(F1::Ln)),
    ("ln", Arity::One(F1::Ln)),
    ("log10", Arity::One(F1::Log10)),
    ("sqrt", Arity::One(F1::Sqrt)),
    ("abs", Arity::One(F1::Abs)),
    ("min", Arity::Many(F2::Min)),
    ("max", Arity::Many(F2::Max)),
    ("pow", Arity::Two(F2::Pow)),
    ("floor", Arity::One(F1::Floor)),
    ("ceil", Arity::One(F1::Ceil)),
    ("sign", Arity::One(F1::Sign)),
];

/// Named constants; variables of the same name take precedence.
const CONSTANTS: &[(&str, f64)] = &[("pi", std::f64::consts::PI), ("e", std::f64::consts::E)];

/// Parse tree, only alive during compilation.
#[derive(Debug, Clone)]
enum Node {
    Num(f64),
    Var(usize),
    Neg(Box<Node>),
    Call1(F1, Box<Node>),
    Call2(F2, Box<Node>, Box<Node>),
}

/// One instruction of the compiled stack program.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Op {
    Const(f64),
    Var(usize),
    Neg,
    /// `a^2` (and `pow(a, 2)`) as `a*a`: the correctly rounded square,
    /// which `powf` also aims at, for a fraction of its cost.
    Square,
    Call1(F1),
    Call2(F2),
}

/// A compiled expression over a fixed list of variables.
#[derive(Debug, Clone, PartialEq)]
pub struct Expr {
    source: String,
    vars: Vec<String>,
    ops: Vec<Op>,
    /// Most operands the program holds at once.
    depth: usize,
}

/// `f'·da`, direction by direction, with a direction along which the
/// operand does not change contributing 0 even where f' is infinite or
/// NaN (`sqrt(x)` at x = 0 does not vary with y).
#[inline(always)]
fn chain<const N: usize>(fp: f64, da: &[f64; N]) -> [f64; N] {
    if fp.is_finite() {
        da.map(|d| fp * d)
    } else {
        da.map(|d| if d == 0.0 { 0.0 } else { fp * d })
    }
}

/// The derivative of `f(a, b)` (value `v`) from those of its operands.
/// `min`/`max` follow the operand they pick and take the mean of both at a
/// tie (the central difference of a kink); `pow` leaves out the term of an
/// operand that does not vary, so that `a^b` with a negative base and a
/// constant exponent has a derivative.
#[inline(always)]
fn derivative2<const N: usize>(f: F2, a: f64, b: f64, v: f64, da: &[f64; N], db: &[f64; N]) -> [f64; N] {
    #[inline(always)]
    fn zip<const N: usize>(da: &[f64; N], db: &[f64; N], g: impl Fn(f64, f64) -> f64) -> [f64; N] {
        std::array::from_fn(|k| g(da[k], db[k]))
    }
    match f {
        F2::Add => zip(da, db, |x, y| x + y),
        F2::Sub => zip(da, db, |x, y| x - y),
        F2::Mul => zip(da, db, |x, y| a * y + b * x),
        F2::Div => zip(da, db, |x, y| (x - v * y) / b),
        F2::Pow => {
            let varies = |d: &[f64; N]| d.iter().any(|&x| x != 0.0);
            let mut out = [0.0; N];
            if varies(da) {
                // b a^(b-1) without a second powf where a ≠ 0
                let fp = if a != 0.0 && v.is_finite() { b * v / a } else { b * a.powf(b - 1.0) };
                out = chain(fp, da);
            }
            if varies(db) {
                // 0^b is 0 for every b > 0: no NaN from 0·ln 0
                let t = chain(if v == 0.0 { 0.0 } else { v * a.ln() }, db);
                for k in 0..N {
                    out[k] += t[k];
                }
            }
            out
        }
        F2::Atan2 => {
            let r2 = a * a + b * b;
            zip(da, db, |x, y| (b * x - a * y) / r2)
        }
        F2::Min | F2::Max => {
            let first = if f == F2::Min { a < b } else { a > b };
            let second = if f == F2::Min { b < a } else { b > a };
            if first || b.is_nan() {
                *da
            } else if second || a.is_nan() {
                *db
            } else {
                zip(da, db, |x, y| 0.5 * (x + y))
            }
        }
    }
}

impl Expr {
    /// Names of the functions an expression may call. `log` and `ln` are
    /// both the natural logarithm; `sign(0)` is 0; `min`/`max` take one or
    /// more arguments; `atan2(y, x)` and `pow(a, b)` take two.
    pub const FUNCTIONS: &'static [&'static str] = &[
        "sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sinh", "cosh", "tanh", "exp", "log",
        "ln", "log10", "sqrt", "abs", "min", "max", "pow", "floor", "ceil", "sign",
    ];

    /// Parses and compiles `text`; `vars` names the values later passed to
    /// [`Expr::eval`], in that order.
    pub fn parse(text: &str, vars: &[&str]) -> Result<Expr, ExprError> {
        let tokens = lex(text)?;
        let mut parser = Parser {
            tokens: &tokens,
            pos: 0,
            vars,
            depth: 0,
        };
        let tree = parser.expr()?;
        parser.expect_end()?;
        let tree = fold(tree);
        let mut ops = Vec::new();
        let max_depth = emit(&tree, &mut ops, 0);
        if max_depth > MAX_STACK {
            return Err(ExprError::TooDeep { column: 1 });
        }
        Ok(Expr {
            source: text.to_string(),
            vars: vars.iter().map(|v| v.to_string()).collect(),
            ops,
            depth: max_depth,
        })
    }

    /// Evaluates the expression; `values[i]` is the value of `vars[i]` given
    /// to [`Expr::parse`].
    ///
    /// # Panics
    /// If `values` is shorter than the variable list and the expression uses
    /// a variable beyond its end.
    pub fn eval(&self, values: &[f64]) -> f64 {
        if self.depth <= SHORT_STACK {
            self.run::<SHORT_STACK>(values)
        } else {
            self.run::<MAX_STACK>(values)
        }
    }

    /// [`Expr::eval`] with a stack of `S ≥ self.depth` entries.
    #[inline(always)]
    fn run<const S: usize>(&self, values: &[f64]) -> f64 {
        let mut stack = [0.0f64; S];
        let mut top = 0usize; // number of live entries
        for op in &self.ops {
            match *op {
                Op::Const(c) => {
                    stack[top] = c;
                    top += 1;
                }
                Op::Var(i) => {
                    stack[top] = values[i];
                    top += 1;
                }
                Op::Neg => stack[top - 1] = -stack[top - 1],
                Op::Square => stack[top - 1] *= stack[top - 1],
                Op::Call1(f) => stack[top - 1] = f.apply(stack[top - 1]),
                Op::Call2(f) => {
                    top -= 1;
                    stack[top - 1] = f.apply(stack[top - 1], stack[top]);
                }
            }
        }
        stack[0]
    }

    /// The value and the gradient with respect to the first `N` variables
    /// (`values[..N]`; the others are held fixed), in one forward-mode
    /// pass over the compiled program: the value is [`Expr::eval`]'s to the
    /// bit, the derivatives exact up to rounding (no finite differences).
    /// No allocation.
    ///
    /// Where the expression is not differentiable the derivative is a
    /// one-sided or averaged one (see `abs`, `min`, `max`), 0 for `floor`,
    /// `ceil` and `sign`, and infinite or NaN where the derivative blows up
    /// (`sqrt` at 0 along a direction it varies in).
    ///
    /// # Panics
    /// As [`Expr::eval`], and if `N` exceeds `values.len()`.
    pub fn eval_gradient<const N: usize>(&self, values: &[f64]) -> (f64, [f64; N]) {
        assert!(N <= values.len(), "eval_gradient: {N} directions but {} values", values.len());
        if self.depth <= SHORT_STACK {
            self.run_gradient::<N, SHORT_STACK>(values)
        } else {
            self.run_gradient::<N, MAX_STACK>(values)
        }
    }

    /// [`Expr::eval_gradient`] with a stack of `S ≥ self.depth` entries.
    #[inline(always)]
    fn run_gradient<const N: usize, const S: usize>(&self, values: &[f64]) -> (f64, [f64; N]) {
        let mut val = [0.0f64; S];
        let mut der = [[0.0f64; N]; S];
        let mut top = 0usize;
        for op in &self.ops {
            match *op {
                Op::Const(c) => {
                    val[top] = c;
                    der[top] = [0.0; N];
                    top += 1;
                }
                Op::Var(i) => {
                    val[top] = values[i];
                    der[top] = std::array::from_fn(|k| if k == i { 1.0 } else { 0.0 });
                    top += 1;
                }
                Op::Neg => {
                    val[top - 1] = -val[top - 1];
                    der[top - 1] = der[top - 1].map(|d| -d);
                }
                Op::Square => {
                    let a = val[top - 1];
                    val[top - 1] = a * a;
                    der[top - 1] = der[top - 1].map(|d| 2.0 * a * d);
                }
                Op::Call1(f) => {
                    let a = val[top - 1];
                    let v = f.apply(a);
                    val[top - 1] = v;
                    der[top - 1] = chain(f.derivative(a, v), &der[top - 1]);
                }
                Op::Call2(f) => {
                    top -= 1;
                    let (a, b) = (val[top - 1], val[top]);
                    let v = f.apply(a, b);
                    val[top - 1] = v;
                    der[top - 1] = derivative2(f, a, b, v, &der[top - 1], &der[top]);
                }
            }
        }
        (val[0], der[0])
    }

    /// Whether the compiled expression reads variable `var` (after constant
    /// folding; `x*0` still counts as using `x`).
    pub fn uses(&self, var: &str) -> bool {
        match self.vars.iter().position(|v| v == var) {
            Some(i) => self.ops.contains(&Op::Var(i)),
            None => false,
        }
    }

    /// The text the expression was parsed from.
    pub fn source(&self) -> &str {
        &self.source
    }

    /// The variable names, in the order [`Expr::eval`] expects values.
    pub fn vars(&self) -> &[String] {
        &self.vars
    }

    /// The value if the expression does not depend on any variable.
    pub fn as_constant(&self) -> Option<f64> {
        match self.ops.as_slice() {
            [Op::Const(c)] => Some(*c),
            _ => None,
        }
    }
}

impl fmt::Display for Expr {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.source)
    }
}

/// Folds operations whose operands are all constants, so that e.g.
/// `2*pi/3` costs one push at evaluation time.
fn fold(node: Node) -> Node {
    match node {
        Node::Neg(a) => match fold(*a) {
            Node::Num(x) => Node::Num(-x),
            a => Node::Neg(Box::new(a)),
        },
        Node::Call1(f, a) => match fold(*a) {
            Node::Num(x) => Node::Num(f.apply(x)),
            a => Node::Call1(f, Box::new(a)),
        },
        Node::Call2(f, a, b) => match (fold(*a), fold(*b)) {
            (Node::Num(x), Node::Num(y)) => Node::Num(f.apply(x, y)),
            (a, b) => Node::Call2(f, Box::new(a), Box::new(b)),
        },
        leaf => leaf,
    }
}

/// Appends the postfix program for `node`; `depth` is the stack height
/// before it runs. Returns the maximum stack height reached.
fn emit(node: &Node, ops: &mut Vec<Op>, depth: usize) -> usize {
    match node {
        Node::Num(x) => {
            ops.push(Op::Const(*x));
            depth + 1
        }
        Node::Var(i) => {
            ops.push(Op::Var(*i));
            depth + 1
        }
        Node::Neg(a) => {
            let d = emit(a, ops, depth);
            ops.push(Op::Neg);
            d
        }
        Node::Call1(f, a) => {
            let d = emit(a, ops, depth);
            ops.push(Op::Call1(*f));
            d
        }
        Node::Call2(F2::Pow, a, b) if matches!(**b, Node::Num(n) if n == 2.0) => {
            let d = emit(a, ops, depth);
            ops.push(Op::Square);
            d
        }
        Node::Call2(f, a, b) => {
            let da = emit(a, ops, depth);
            let db = emit(b, ops, depth + 1);
            ops.push(Op::Call2(*f));
            da.max(db)
        }
    }
}

/// A lexical token with its 1-based character column.
#[derive(Debug, Clone, PartialEq)]
struct Token {
    kind: Tok,
    column: usize,
}

#[derive(Debug, Clone, PartialEq)]
enum Tok {
    Num(f64),
    Name(String),
    Sym(char),
    End,
}

impl Tok {
    /// How the token is named in error messages.
    fn describe(&self) -> String {
        match self {
            Tok::Num(x) => format!("number `{x}`"),
            Tok::Name(n) => format!("`{n}`"),
            Tok::Sym(c) => format!("`{c}`"),
            Tok::End => "end of input".to_string(),
        }
    }
}

/// Splits `text` into tokens, always ending with [`Tok::End`].
fn lex(text: &str) -> Result<Vec<Token>, ExprError> {
    let chars: Vec<char> = text.chars().collect();
    let mut tokens = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        let column = i + 1;
        if c.is_whitespace() {
            i += 1;
        } else if c.is_ascii_digit() || c == '.' {
            let (value, len) = lex_number(&chars[i..], column)?;
            tokens.push(Token {
                kind: Tok::Num(value),
                column,
            });
            i += len;
        } else if c.is_alphabetic() || c == '_' {
            let len = chars[i..]
                .iter()
                .take_while(|c| c.is_alphanumeric() || **c == '_')
                .count();
            let name: String = chars[i..i + len].iter().collect();
            tokens.push(Token {
                kind: Tok::Name(name),
                column,
            });
            i += len;
        } else if "+-*/^(),".contains(c) {
            tokens.push(Token {
                kind: Tok::Sym(c),
                column,
            });
            i += 1;
        } else {
            return Err(ExprError::UnexpectedChar { ch: c, column });
        }
    }
    tokens.push(Token {
        kind: Tok::End,
        column: chars.len() + 1,
    });
    Ok(tokens)
}

/// Reads a number literal at the start of `chars`: digits, an optional
/// fraction and an optional exponent. Returns the value and its length.
fn lex_number(chars: &[char], column: usize) -> Result<(f64, usize), ExprError> {
    let digits = |from: usize| {
        chars[from..]
            .iter()
            .take_while(|c| c.is_ascii_digit())
            .count()
    };
    let mut len = digits(0);
    if chars.get(len) == Some(&'.') {
        len += 1 + digits(len + 1);
    }
    if matches!(chars.get(len), Some('e' | 'E')) {
        // Only an exponent if digits follow; otherwise `2e` is malformed
        // rather than silently meaning `2` followed by the constant `e`.
        let mut exp_len = 1;
        if matches!(chars.get(len + 1), Some('+' | '-')) {
            exp_len += 1;
        }
        let exp_digits = digits(len + exp_len);
        len += exp_len + exp_digits;
        if exp_digits == 0 {
            return Err(invalid_number(chars, len, column));
        }
    }
    // A trailing letter or second dot (`1.2.3`, `3x`) is a malformed literal.
    let glued = chars
        .get(len)
        .is_some_and(|c| c.is_alphanumeric() || *c == '.' || *c == '_');
    let text: String = chars[..len].iter().collect();
    match text.parse::<f64>() {
        Ok(value) if !glued && text != "." => Ok((value, len)),
        _ => {
            let extra = chars[len..]
                .iter()
                .take_while(|c| c.is_alphanumeric() || **c == '.')
                .count();
            Err(invalid_number(chars, len + extra, column))
        }
    }
}

fn invalid_number(chars: &[char], len: usize, column: usize) -> ExprError {
    let len = len.min(chars.len());
    ExprError::InvalidNumber {
        text: chars[..len].iter().collect(),
        column,
    }
}

/// Recursive-descent parser over the token list.
struct Parser<'a> {
    tokens: &'a [Token],
    pos: usize,
    vars: &'a [&'a str],
    depth: usize,
}

impl Parser<'_> {
    fn peek(&self) -> &Token {
        &self.tokens[self.pos]
    }

    fn bump(&mut self) -> Token {
        let t = self.tokens[self.pos].clone();
        if t.kind != Tok::End {
            self.pos += 1;
        }
        t
    }

    /// Consumes the symbol `c` if it is next.
    fn eat(&mut self, c: char) -> bool {
        if self.peek().kind == Tok::Sym(c) {
            self.pos += 1;
            true
        } else {
            false
        }
    }

    fn error_here(&self, expected: &str) -> ExprError {
        let t = self.peek();
        ExprError::Expected {
            expected: expected.to_string(),
            found: t.kind.describe(),
            column: t.column,
        }
    }

    fn expect_end(&self) -> Result<(), ExprError> {
        match self.peek().kind {
            Tok::End => Ok(()),
            Tok::Sym(')') => Err(self.error_here("an operator or end of input (unbalanced `)`)")),
            _ => Err(self.error_here("an operator or end of input")),
        }
    }

    /// Guards recursion depth; call on entering a nested construct.
    fn enter(&mut self) -> Result<(), ExprError> {
        self.depth += 1;
        if self.depth > MAX_NESTING {
            return Err(ExprError::TooDeep {
                column: self.peek().column,
            });
        }
        Ok(())
    }

    fn expr(&mut self) -> Result<Node, ExprError> {
        let mut lhs = self.term()?;
        loop {
            let op = if self.eat('+') {
                F2::Add
            } else if self.eat('-') {
                F2::Sub
            } else {
                return Ok(lhs);
            };
            let rhs = self.term()?;
            lhs = Node::Call2(op, Box::new(lhs), Box::new(rhs));
        }
    }

    fn term(&mut self) -> Result<Node, ExprError> {
        let mut lhs = self.unary()?;
        loop {
            let op = if self.eat('*') {
                F2::Mul
            } else if self.eat('/') {
                F2::Div
            } else {
                return Ok(lhs);
            };
            let rhs = self.unary()?;
            lhs = Node::Call2(op, Box::new(lhs), Box::new(rhs));
        }
    }

    fn unary(&mut self) -> Result<Node, ExprError> {
        self.enter()?;
        let node = if self.eat('-') {
            Node::Neg(Box::new(self.unary()?))
        } else if self.eat('+') {
            self.unary()?
        } else {
            self.power()?
        };
        self.depth -= 1;
        Ok(node)
    }

    fn power(&mut self) -> Result<Node, ExprError> {
        let base = self.primary()?;
        if self.eat('^') {
            // The exponent is a `unary`, which makes `^` right-associative
            // and lets `2^-1` work.
            let exponent = self.unary()?;
            return Ok(Node::Call2(F2::Pow, Box::new(base), Box::new(exponent)));
        }
        Ok(base)
    }

    fn primary(&mut self) -> Result<Node, ExprError> {
        let token = self.bump();
        match token.kind {
            Tok::Num(x) => Ok(Node::Num(x)),
            Tok::Sym('(') => {
                self.enter()?;
                let inner = self.expr()?;
                self.close_paren()?;
                self.depth -= 1;
                Ok(inner)
            }
            Tok::Name(name) if self.peek().kind == Tok::Sym('(') => self.call(&name, token.column),
            Tok::Name(name) => self.name(&name, token.column),
            _ => {
                self.pos -= usize::from(token.kind != Tok::End);
                Err(self.error_here("a number, variable, function or `(`"))
            }
        }
    }

    fn close_paren(&mut self) -> Result<(), ExprError> {
        if self.eat(')') {
            Ok(())
        } else {
            Err(self.error_here("`)`"))
        }
    }

    /// A bare name: a variable or constant (or a function missing its `(`).
    fn name(&self, name: &str, column: usize) -> Result<Node, ExprError> {
        if let Some(i) = self.vars.iter().position(|v| *v == name) {
            return Ok(Node::Var(i));
        }
        if let Some((_, value)) = CONSTANTS.iter().find(|(n, _)| *n == name) {
            return Ok(Node::Num(*value));
        }
        if FUNCTIONS.iter().any(|(n, _)| *n == name) {
            return Err(self.error_here(&format!("`(` after function `{name}`")));
        }
        let known: Vec<&str> = self
            .vars
            .iter()
            .copied()
            .chain(CONSTANTS.iter().map(|(n, _)| *n))
            .collect();
        Err(ExprError::UnknownVariable {
            name: name.to_string(),
            column,
            known: known.join(", "),
        })
    }

    /// A function call; the next token is the opening parenthesis.
    fn call(&mut self, name: &str, column: usize) -> Result<Node, ExprError> {
        let Some((_, arity)) = FUNCTIONS.iter().find(|(n, _)| *n == name) else {
            return Err(ExprError::UnknownFunction {
                name: name.to_string(),
                column,
                known: Expr::FUNCTIONS.join(", "),
            });
        };
        self.enter()?;
        self.bump(); // '('
        let mut args = vec![self.expr()?];
        while self.eat(',') {
            args.push(self.expr()?);
        }
        self.close_paren()?;
        self.depth -= 1;
        build_call(name, column, *arity, args)
    }
}

/// Checks the argument count and builds the call node.
fn build_call(name: &str, column: usize, arity: Arity, args: Vec<Node>) -> Result<Node, ExprError> {
    let count_error = |expected: &str| ExprError::ArgumentCount {
        name: name.to_string(),
        column,
        expected: expected.to_string(),
        got: args.len(),
    };
    match arity {
        Arity::One(f) if args.len() == 1 => {
            Ok(Node::Call1(f, Box::new(args.into_iter().next().unwrap())))
        }
        Arity::One(_) => Err(count_error("1")),
        Arity::Two(f) if args.len() == 2 => {
            let mut it = args.into_iter();
            let (a, b) = (it.next().unwrap(), it.next().unwrap());
            Ok(Node::Call2(f, Box::new(a), Box::new(b)))
        }
        Arity::Two(_) => Err(count_error("2")),
        // The grammar always yields at least one argument, so fold pairwise.
        Arity::Many(f) => Ok(args
            .into_iter()
            .reduce(|a, b| Node::Call2(f, Box::new(a), Box::new(b)))
            .expect("at least one argument")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{E, PI};

    const VARS: &[&str] = &["x", "y", "t"];

    fn ev(text: &str, x: f64, y: f64, t: f64) -> f64 {
        Expr::parse(text, VARS)
            .unwrap_or_else(|e| panic!("{text}: {e}"))
            .eval(&[x, y, t])
    }

    fn err(text: &str) -> ExprError {
        Expr::parse(text, VARS).expect_err(text)
    }

    fn close(a: f64, b: f64) -> bool {
        a == b || (a - b).abs() <= 1e-14 * a.abs().max(b.abs()) || (a.is_nan() && b.is_nan())
    }

    #[test]
    fn numbers() {
        for (text, value) in [
            ("1", 1.0),
            ("1.5", 1.5),
            ("1e-3", 1e-3),
            (".5", 0.5),
            ("2.", 2.0),
            ("1E+2", 100.0),
            ("0.25e1", 2.5),
        ] {
            assert_eq!(ev(text, 0.0, 0.0, 0.0), value, "{text}");
        }
    }

    #[test]
    fn values_match_rust() {
        let samples = [
            (0.3, -1.7, 2.0),
            (1.25, 0.5, -0.75),
            (-2.0, 3.5, 0.1),
            (0.9, 0.2, 10.0),
        ];
        type F = fn(f64, f64, f64) -> f64;
        let cases: &[(&str, F)] = &[
            ("x + y * t", |x, y, t| x + y * t),
            ("(x + y) * t", |x, y, t| (x + y) * t),
            ("x - y - t", |x, y, t| x - y - t),
            ("x / y / t", |x, y, t| x / y / t),
            ("x^2 + y^2", |x, y, _| x.powf(2.0) + y.powf(2.0)),
            ("sin(x) * cos(y) + tan(t)", |x, y, t| {
                x.sin() * y.cos() + t.tan()
            }),
            ("asin(x/3) + acos(y/4) + atan(t)", |x, y, t| {
                (x / 3.0).asin() + (y / 4.0).acos() + t.atan()
            }),
            ("atan2(y, x)", |x, y, _| y.atan2(x)),
            ("sinh(x) + cosh(y) - tanh(t)", |x, y, t| {
                x.sinh() + y.cosh() - t.tanh()
            }),
            (
                "exp(x) + log(abs(y)) + ln(abs(t)) + log10(abs(x))",
                |x, y, t| x.exp() + y.abs().ln() + t.abs().ln() + x.abs().log10(),
            ),
            ("sqrt(abs(x*y))", |x, y, _| (x * y).abs().sqrt()),
            ("min(x, y, t) + max(x, y, t)", |x, y, t| {
                x.min(y).min(t) + x.max(y).max(t)
            }),
            ("min(x)", |x, _, _| x),
            ("pow(abs(x), y)", |x, y, _| x.abs().powf(y)),
            ("floor(x*y) + ceil(t) + sign(y)", |x, y, t| {
                (x * y).floor() + t.ceil() + y.signum()
            }),
            ("0.1*sin(2*pi*x) + e^y", |x, y, _| {
                0.1 * (2.0 * PI * x).sin() + E.powf(y)
            }),
            ("1 - 2*x*y/(1 + t^2)^1.5", |x, y, t| {
                1.0 - 2.0 * x * y / (1.0 + t.powf(2.0)).powf(1.5)
            }),
        ];
        for &(x, y, t) in &samples {
            for (text, f) in cases {
                let (got, want) = (ev(text, x, y, t), f(x, y, t));
                assert!(close(got, want), "{text} at {x},{y},{t}: {got} vs {want}");
            }
        }
    }

    #[test]
    fn precedence() {
        let x = 3.0;
        assert_eq!(ev("-x^2", x, 0.0, 0.0), -9.0);
        assert_eq!(ev("(-x)^2", x, 0.0, 0.0), 9.0);
        assert_eq!(ev("2^3^2", 0.0, 0.0, 0.0), 512.0);
        assert_eq!(ev("2^-1", 0.0, 0.0, 0.0), 0.5);
        assert_eq!(ev("-2^-2", 0.0, 0.0, 0.0), -0.25);
        assert_eq!(ev("1 + 2 * 3", 0.0, 0.0, 0.0), 7.0);
        assert_eq!(ev("8 / 4 / 2", 0.0, 0.0, 0.0), 1.0);
        assert_eq!(ev("8 - 4 - 2", 0.0, 0.0, 0.0), 2.0);
        assert_eq!(ev("2 * -3", 0.0, 0.0, 0.0), -6.0);
        assert_eq!(ev("--2", 0.0, 0.0, 0.0), 2.0);
        assert_eq!(ev("+-+2", 0.0, 0.0, 0.0), -2.0);
        assert_eq!(ev("2*x^2", x, 0.0, 0.0), 18.0);
        assert_eq!(ev("-x*2", x, 0.0, 0.0), -6.0);
        assert_eq!(ev("((1))", 0.0, 0.0, 0.0), 1.0);
    }

    #[test]
    fn constants_and_shadowing() {
        assert_eq!(ev("pi", 0.0, 0.0, 0.0), PI);
        assert_eq!(ev("e", 0.0, 0.0, 0.0), E);
        let shadow = Expr::parse("e + 1", &["e"]).unwrap();
        assert_eq!(shadow.eval(&[5.0]), 6.0);
    }

    #[test]
    fn sign_of_zero_is_zero() {
        assert_eq!(ev("sign(0)", 0.0, 0.0, 0.0), 0.0);
        assert_eq!(ev("sign(x)", -0.5, 0.0, 0.0), -1.0);
    }

    #[test]
    fn uses_and_folding() {
        let e = Expr::parse("x*0 + 2*pi", VARS).unwrap();
        assert!(e.uses("x"));
        assert!(!e.uses("y"));
        assert!(!e.uses("zz"));
        let c = Expr::parse("2*pi/4 + sqrt(16)", VARS).unwrap();
        assert_eq!(c.as_constant(), Some(2.0 * PI / 4.0 + 4.0));
        assert_eq!(c.ops.len(), 1);
        assert_eq!(e.to_string(), "x*0 + 2*pi");
    }

    #[test]
    fn long_sums_do_not_grow_the_stack() {
        let text = vec!["x"; 500].join(" + ");
        assert_eq!(ev(&text, 1.0, 0.0, 0.0), 500.0);
    }

    #[test]
    fn error_unknown_variable() {
        let e = err("x + y * z");
        assert_eq!(
            e.to_string(),
            "unknown variable `z` at column 9 (known: x, y, t, pi, e)"
        );
        assert!(matches!(e, ExprError::UnknownVariable { column: 9, .. }));
    }

    #[test]
    fn error_missing_paren() {
        let e = err("sin(x + (y)");
        assert_eq!(
            e.to_string(),
            "expected `)` at column 12, found end of input"
        );
        assert!(matches!(
            err("(x, y)"),
            ExprError::Expected { column: 3, .. }
        ));
    }

    #[test]
    fn error_unbalanced_and_trailing() {
        assert!(matches!(
            err("x + 1)"),
            ExprError::Expected { column: 6, .. }
        ));
        assert!(matches!(err("x y"), ExprError::Expected { column: 3, .. }));
        assert!(err("x y").to_string().contains("found `y`"));
    }

    #[test]
    fn error_missing_operand() {
        for (text, column) in [
            ("", 1),
            ("x +", 4),
            ("* x", 1),
            ("()", 2),
            ("sin()", 5),
            ("max(x,)", 7),
        ] {
            match err(text) {
                ExprError::Expected { column: c, .. } => assert_eq!(c, column, "{text}"),
                other => panic!("{text}: {other}"),
            }
        }
    }

    #[test]
    fn error_unknown_function() {
        let e = err("1 + foo(x)");
        assert!(matches!(e, ExprError::UnknownFunction { column: 5, .. }));
        assert!(e
            .to_string()
            .starts_with("unknown function `foo` at column 5"));
        // A variable is not callable.
        assert!(matches!(
            err("x(2)"),
            ExprError::UnknownFunction { column: 1, .. }
        ));
    }

    #[test]
    fn error_function_without_parens() {
        let e = err("sin + 1");
        assert_eq!(
            e.to_string(),
            "expected `(` after function `sin` at column 5, found `+`"
        );
    }

    #[test]
    fn error_argument_count() {
        let e = err("atan2(y)");
        assert_eq!(
            e.to_string(),
            "function `atan2` at column 1 takes 2 argument(s), got 1"
        );
        assert!(matches!(
            err("sin(x, y)"),
            ExprError::ArgumentCount { got: 2, .. }
        ));
        assert!(matches!(
            err("2*pow(1,2,3)"),
            ExprError::ArgumentCount {
                column: 3,
                got: 3,
                ..
            }
        ));
    }

    #[test]
    fn error_bad_characters_and_numbers() {
        assert_eq!(
            err("x # 2"),
            ExprError::UnexpectedChar { ch: '#', column: 3 }
        );
        assert_eq!(
            err("1 + 2e"),
            ExprError::InvalidNumber {
                text: "2e".into(),
                column: 5
            }
        );
        assert_eq!(
            err("1.2.3"),
            ExprError::InvalidNumber {
                text: "1.2.3".into(),
                column: 1
            }
        );
        assert_eq!(
            err("3x"),
            ExprError::InvalidNumber {
                text: "3x".into(),
                column: 1
            }
        );
        assert!(matches!(
            err("."),
            ExprError::InvalidNumber { column: 1, .. }
        ));
    }

    #[test]
    fn columns_count_characters_not_bytes() {
        assert!(matches!(
            err("é + q"),
            ExprError::UnknownVariable { column: 1, .. }
        ));
        assert!(matches!(
            err("x + é"),
            ExprError::UnknownVariable { column: 5, .. }
        ));
    }

    /// The gradient in x, y (t held fixed) of `text` at a point.
    fn grad(text: &str, x: f64, y: f64, t: f64) -> (f64, [f64; 2]) {
        Expr::parse(text, VARS).unwrap_or_else(|e| panic!("{text}: {e}")).eval_gradient::<2>(&[x, y, t])
    }

    #[test]
    fn gradients_match_exact_derivatives() {
        type G = fn(f64, f64, f64) -> [f64; 2];
        let cases: &[(&str, G)] = &[
            ("x^2 + y^2 - 0.25", |x, y, _| [2.0 * x, 2.0 * y]),
            ("x*y*t - x/y", |x, y, t| [y * t - 1.0 / y, x * t + x / (y * y)]),
            ("-x^3 + pow(y, 4)", |x, y, _| [-3.0 * x * x, 4.0 * y.powi(3)]),
            ("sqrt(x^2 + y^2) - 1", |x, y, _| {
                let r = x.hypot(y);
                [x / r, y / r]
            }),
            ("(sqrt(x^2 + y^2) - 1)^2 + t^2 - 0.25", |x, y, _| {
                let r = x.hypot(y);
                [2.0 * (r - 1.0) * x / r, 2.0 * (r - 1.0) * y / r]
            }),
            ("exp(x*y) + ln(x^2 + 1) + log10(y^2 + 2)", |x, y, _| {
                let e = (x * y).exp();
                [y * e + 2.0 * x / (x * x + 1.0), x * e + 2.0 * y / ((y * y + 2.0) * std::f64::consts::LN_10)]
            }),
            ("sin(2*x) * cos(y) + tan(y/4)", |x, y, _| {
                let c = (y / 4.0).cos();
                [2.0 * (2.0 * x).cos() * y.cos(), -(2.0 * x).sin() * y.sin() + 0.25 / (c * c)]
            }),
            ("asin(x/4) + acos(y/5) + atan(x*y)", |x, y, _| {
                let d = 1.0 + (x * y).powi(2);
                [0.25 / (1.0 - x * x / 16.0).sqrt() + y / d, -0.2 / (1.0 - y * y / 25.0).sqrt() + x / d]
            }),
            ("sinh(x) + cosh(y) + tanh(x - y)", |x, y, _| {
                let s = 1.0 - (x - y).tanh().powi(2);
                [x.cosh() + s, y.sinh() - s]
            }),
            ("atan2(y, x)", |x, y, _| {
                let r2 = x * x + y * y;
                [-y / r2, x / r2]
            }),
            ("atan2(x - 1, y + 2) * t", |x, y, t| {
                let (a, b) = (x - 1.0, y + 2.0);
                let r2 = a * a + b * b;
                [t * b / r2, -t * a / r2]
            }),
            ("abs(x)^1.5 + (y^2 + 1)^-0.5", |x, y, _| [1.5 * x.abs().sqrt() * x.signum(), -y * (y * y + 1.0).powf(-1.5)]),
            ("(x^2 + 1)^y", |x, y, _| {
                let a = x * x + 1.0;
                [y * a.powf(y - 1.0) * 2.0 * x, a.powf(y) * a.ln()]
            }),
            ("2^x * e^y", |x, y, _| {
                let v = 2f64.powf(x) * y.exp();
                [v * 2f64.ln(), v]
            }),
            ("min(x, y) + 2*max(x^2, y, t)", |x, y, t| {
                let dmin = if x < y { [1.0, 0.0] } else { [0.0, 1.0] };
                let dmax = if x * x > y.max(t) { [2.0 * x, 0.0] } else if y > t { [0.0, 1.0] } else { [0.0, 0.0] };
                [dmin[0] + 2.0 * dmax[0], dmin[1] + 2.0 * dmax[1]]
            }),
            ("floor(x) + ceil(y) + sign(x*y) + 3", |_, _, _| [0.0, 0.0]),
        ];
        let points = [(0.3, -1.7, 2.0), (1.25, 0.5, -0.75), (-2.0, 3.5, 0.1), (0.9, 0.2, 10.0), (-0.6, -0.45, 1.5)];
        for &(x, y, t) in &points {
            for (text, exact) in cases {
                let (v, g) = grad(text, x, y, t);
                // the value is eval's, to the bit
                assert_eq!(v.to_bits(), ev(text, x, y, t).to_bits(), "{text} at {x},{y},{t}");
                let want = exact(x, y, t);
                let scale = 1.0 + want[0].abs().max(want[1].abs());
                for k in 0..2 {
                    assert!((g[k] - want[k]).abs() <= 1e-13 * scale, "{text} at {x},{y},{t}: d{k} = {} vs {}", g[k], want[k]);
                }
            }
        }
    }

    #[test]
    fn gradients_of_a_deep_program_and_of_the_held_variables() {
        // nine nested levels need more than the short stack
        let text = "1 + x*(2 + y*(3 + x*(4 + y*(5 + x*(6 + y*(7 + x*(8 + y*(9 + x))))))))";
        let e = Expr::parse(text, VARS).unwrap();
        assert!(e.depth > SHORT_STACK, "{}", e.depth);
        let f = |x: f64, y: f64| e.eval(&[x, y, 0.0]);
        let (x, y) = (0.7, -0.4);
        let (v, g) = e.eval_gradient::<2>(&[x, y, 0.0]);
        assert_eq!(v, f(x, y));
        // a polynomial: a central difference of step h is exact to O(h²)
        // (times its third derivative, about 500 here) plus rounding
        let h = 1e-5;
        let fd = [(f(x + h, y) - f(x - h, y)) / (2.0 * h), (f(x, y + h) - f(x, y - h)) / (2.0 * h)];
        for k in 0..2 {
            assert!((g[k] - fd[k]).abs() < 1e-6 * (1.0 + fd[k].abs()), "{k}: {} vs {}", g[k], fd[k]);
        }
        // N = 1: y and t are held fixed; N = 3: t is a direction too
        assert_eq!(grad("x*y + t", 2.0, 3.0, 4.0).1, [3.0, 2.0]);
        let e = Expr::parse("x*y + t^2", VARS).unwrap();
        assert_eq!(e.eval_gradient::<1>(&[2.0, 3.0, 4.0]), (22.0, [3.0]));
        assert_eq!(e.eval_gradient::<3>(&[2.0, 3.0, 4.0]), (22.0, [3.0, 2.0, 8.0]));
        assert_eq!(Expr::parse("5", VARS).unwrap().eval_gradient::<3>(&[1.0, 1.0, 1.0]), (5.0, [0.0; 3]));
    }

    #[test]
    fn gradients_where_the_expression_is_not_smooth() {
        // kinks: the mean of the one-sided slopes, as a central difference
        assert_eq!(grad("abs(x) + abs(y - 1)", 0.0, 1.0, 0.0).1, [0.0, 0.0]);
        assert_eq!(grad("min(x, y)", 0.5, 0.5, 0.0).1, [0.5, 0.5]);
        assert_eq!(grad("max(x, 2*y)", 1.0, 0.5, 0.0).1, [0.5, 1.0]);
        // away from a tie, the branch taken
        assert_eq!(grad("max(x, 2*y)", 1.0, 0.4, 0.0).1, [1.0, 0.0]);
        // sqrt at 0: infinite along the direction it varies in, 0 across
        let (v, g) = grad("sqrt(x)", 0.0, 1.0, 0.0);
        assert_eq!(v, 0.0);
        assert!(g[0].is_infinite() && g[1] == 0.0, "{g:?}");
        // 0^b for b > 0 varies with neither; a negative base with a
        // constant exponent is differentiable
        assert_eq!(grad("x^y", 0.0, 2.5, 0.0).1, [0.0, 0.0]);
        assert_eq!(grad("x^3", -2.0, 0.0, 0.0).1, [12.0, 0.0]);
        assert_eq!(grad("x^2", -3.0, 0.0, 0.0), (9.0, [-6.0, 0.0]));
    }

    #[test]
    fn squares_compile_to_a_product() {
        for text in ["x^2", "pow(x, 2)", "x^(1 + 1)"] {
            let e = Expr::parse(text, VARS).unwrap();
            assert_eq!(e.ops, vec![Op::Var(0), Op::Square], "{text}");
            for x in [0.3, -1.7, 1e200, -0.0, f64::INFINITY] {
                assert_eq!(e.eval(&[x, 0.0, 0.0]).to_bits(), x.powf(2.0).to_bits(), "{text} at {x}");
            }
            assert!(e.eval(&[f64::NAN, 0.0, 0.0]).is_nan());
        }
        assert_eq!(Expr::parse("x^2.5", VARS).unwrap().ops, vec![Op::Var(0), Op::Const(2.5), Op::Call2(F2::Pow)]);
    }

    #[test]
    fn error_too_deep() {
        let deep = format!("{}x{}", "(".repeat(1000), ")".repeat(1000));
        assert!(matches!(err(&deep), ExprError::TooDeep { .. }));
        // Right-nested powers need one stack slot per level.
        let tower = vec!["x"; 100].join("^");
        assert!(matches!(err(&tower), ExprError::TooDeep { .. }));
    }
}
