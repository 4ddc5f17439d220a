//! The body of a `Group`: `numObjects`, `MaterialIndex` lines and the objects (legacy-format.md
//! §3).

use super::super::ast::*;
use super::super::error::Problem;
use super::{check_count, plural, Parser};

impl Parser<'_> {
    /// After `Group`: `{ numObjects N (MaterialIndex k | object)* }`.
    pub(super) fn group_body(&mut self) -> Result<Vec<ObjectNode>, Problem> {
        let n = self.open_counted("Group", "numObjects")?;
        let mut items = Vec::new();
        loop {
            let Some(t) = self.lx.peek() else {
                return Err(self.unexpected("an object, `MaterialIndex` or `}`"));
            };
            match t.text {
                "}" => break,
                "MaterialIndex" => {
                    self.lx.next();
                    let k = self.int("material index")?;
                    let count = self.num_materials.unwrap_or(0);
                    if k.value < 0 || k.value as u64 >= count as u64 {
                        let help = if self.num_materials.is_none() {
                            "there is no Materials block before this Group; materials must be defined first".to_string()
                        } else {
                            format!("indices are 0-based: use 0 to {}", count.saturating_sub(1))
                        };
                        return Err(Problem::at(
                            k.span,
                            format!(
                                "MaterialIndex {} is out of range: there {} {count} material{}",
                                k.value,
                                if count == 1 { "is" } else { "are" },
                                plural(count)
                            ),
                        )
                        .help(help));
                    }
                    self.material_index_used = true;
                    self.current_material = Some(k.value as usize);
                }
                "numObjects" => {
                    return Err(Problem::at(t.span, "`numObjects` given twice in one Group"));
                }
                _ => items.push(self.object()?),
            }
        }
        check_count(
            n,
            items.len(),
            "numObjects",
            "group",
            "object",
            " (MaterialIndex lines are not counted)",
        )?;
        self.close("Group")?;
        Ok(items)
    }
}
