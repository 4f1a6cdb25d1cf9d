//! The viewer's sliders for either body ([`AnyBody`], the library's): a template's ARKit
//! face units and phenotype, EHM's expression, eyelid and shape coefficients.

use guava::body::{AnyBody, Posable, TargetGroup};

/// A row of sliders: the coefficient's index, its name and range.
pub struct Slider {
    pub index: usize,
    pub name: String,
    pub range: [f32; 2],
}

/// Sliders under one heading.
pub struct SliderGroup {
    pub title: &'static str,
    pub sliders: Vec<Slider>,
    pub open: bool,
}

/// EHM's PCA coefficients are in standard deviations; ±3 covers the tracked range.
const EHM_COEFFICIENT_RANGE: [f32; 2] = [-3.0, 3.0];

/// The coefficient sliders, grouped as the body's parameters are.
pub fn slider_groups(body: &AnyBody) -> Vec<SliderGroup> {
    match body {
        AnyBody::Template(m) => [
            ("Expression (ARKit face units)", TargetGroup::Expression),
            ("Shape (phenotype ends)", TargetGroup::Shape),
        ]
        .into_iter()
        .map(|(title, group)| SliderGroup {
            title,
            sliders: m
                .targets_in(group)
                .map(|(index, t)| Slider {
                    index,
                    name: t.name.clone(),
                    range: t.reach(),
                })
                .collect(),
            open: group == TargetGroup::Expression,
        })
        .collect(),
        AnyBody::Ehm(m) => {
            let groups = [
                ("FLAME expression", "flame_expression_", true),
                ("Eyelids", "eyelid_", true),
                ("SMPL-X expression", "expression_", false),
                ("SMPL-X shape", "shape_", false),
                ("FLAME shape", "flame_shape_", false),
            ];
            groups
                .into_iter()
                .map(|(title, prefix, open)| SliderGroup {
                    title,
                    sliders: m
                        .parameter_names()
                        .enumerate()
                        .filter(|(_, n)| n.starts_with(prefix))
                        .map(|(index, name)| Slider {
                            index,
                            name: name.to_owned(),
                            range: if prefix == "eyelid_" {
                                [0.0, 1.0]
                            } else {
                                EHM_COEFFICIENT_RANGE
                            },
                        })
                        .collect(),
                    open,
                })
                .collect()
        }
    }
}
