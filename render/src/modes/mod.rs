//! The `optik render` modes beyond one image, as library entry points: [`benchmark`] (the
//! specialised pipeline against the all-effects one), [`convergence`] (relative MSE against
//! time per accuracy setting) and its [`plot`].

pub mod benchmark;
pub mod convergence;
pub mod plot;

#[cfg(test)]
mod tests;
