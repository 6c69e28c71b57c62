//! The formula and scene languages: text → `logos` tokens → lalrpop syntax
//! tree → expression graph, with located errors all the way.
//!
//! ```
//! use lgc::expr::Context;
//! let ast = lgc::lang::parse("let r = 2; x^2 + y^2 - r").unwrap();
//! assert_eq!(ast.bindings.len(), 1);
//! let mut ctx = Context::new();
//! let f = lgc::lang::lower(&mut ctx, &ast).unwrap();
//! assert_eq!(lgc::expr::to_source(&ctx, f), "x^2+y^2-2");
//! ```

pub mod ast;
mod error;
pub mod functions;
mod lexer;
mod lower;
mod parser;
mod vm;

pub use error::{line_column, ErrorKind, FormulaError};
pub use lexer::read_number;
pub use lower::{enclose_constant, lower, NotConstant, MAX_LOWERING_STEPS};
pub use parser::{parse, parse_scene, MAX_TOKENS};
pub use vm::parse_vm;

pub(crate) use lexer::{Lexer, Token};
pub(crate) use lower::{check_bindable, lower_in, Scope};
