pub mod lathe;
