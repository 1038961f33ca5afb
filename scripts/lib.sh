# Shared by the measuring scripts (sourced from the repository's root).

# Sets `bin` to the ballfield binary: $BALLFIELD_BIN when set (to measure another build), else
# the release build of this checkout, built first.
ballfield_bin() {
  if [ -n "${BALLFIELD_BIN:-}" ]; then
    bin=$BALLFIELD_BIN
  else
    cargo build --release --quiet
    bin="${CARGO_TARGET_DIR:-target}/release/ballfield"
  fi
}

# lattice_scene FILE NAME N EFFECTS: writes a scene of N balls of 2 m and 1 kg on a lattice, moving
# at 5 m/s, covering 20 % of a field of aspect 1.6 (the scale benches' field: 501 m × 313 m at
# 10,000 balls, 1,585 m × 991 m at 100,000), with the [effects] lines EFFECTS.
lattice_scene() {
  local file=$1 name=$2 n=$3 effects=$4 width height
  read -r width height < <(python3 -c "import math; a=$n*math.pi/0.2; w=math.sqrt(a*1.6); print(f'{w:.3f} {a/w:.3f}')")
  cat > "$file" <<TOML
name = "$name"
[field]
width = $width
height = $height
[simulation]
max-balls = $n
[effects]
$effects
[[generate]]
count = $n
diameter = 2.0
mass = 1.0
speed = 5.0
layout = "lattice"
gap = 1.0
TOML
}
