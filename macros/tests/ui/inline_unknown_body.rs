mbdc_macros::model! {
    model pendulum {
        gravity (0, 0, -9.81) m/s^2
        body bob { mass 1 kg; inertia sphere(radius: 1 cm); position (0, 0, -1) m }
        joint pivot = spherical(ground @ (0, 0, 0), bobb @ (0, 0, 1) m)
        simulate { duration 1 s; step 1 ms }
    }
}

fn main() {}
