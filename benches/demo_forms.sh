# Sourced by the benchmark scripts: writes the demo's model in the forms a model file allows
# (as bundled, t0 pooled, absolute aging, both) to $1/models/, with data paths made absolute
# from the repository root $2: demo.toml, pooled.toml, absolute.toml, absolute-pooled.toml.
write_demo_forms() {
  local out=$1 root=$2
  mkdir -p "$out/models"
  demo() { sed "s#\.\./data/#$root/data/#" "$root/models/demo.toml"; }
  demo > "$out/models/demo.toml"
  { demo; printf '\n[pooling]\nt0 = true\n'; } > "$out/models/pooled.toml"
  { echo 'aging = "absolute"'; demo; } > "$out/models/absolute.toml"
  { echo 'aging = "absolute"'; demo; printf '\n[pooling]\nt0 = true\n'; } > "$out/models/absolute-pooled.toml"
}
