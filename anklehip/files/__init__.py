"""Files: where things are (paths), reading text and TOML (text), scenarios, writing results
(output), an FMU's interface (info), and SSP / container-FMU export."""
