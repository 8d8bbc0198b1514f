fn main() {
    std::process::exit(wisptree::cli::main());
}
