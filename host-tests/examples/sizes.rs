//! Sizes of the plant types (all f32/u8 fields: the same on the Cortex-M target).
fn main() {
    println!(
        "Plant {} B, PlantState {} B, SineDrive {} B",
        std::mem::size_of::<geared_servo::Plant>(),
        std::mem::size_of::<geared_servo::PlantState>(),
        std::mem::size_of::<geared_servo::SineDrive>()
    );
}
