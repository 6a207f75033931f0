mbdc_macros::model! {
    model pendulum {
        body bob { mass 1 kg; inertia sphere(radius: 1 cm) position (0, 0, -1) m }
    }
}

fn main() {}
