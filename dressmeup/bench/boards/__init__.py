"""Leaderboards: results checked against their editions (`verify`), built into a
`board.Leaderboard` (`leaderboard`, `board_stats`) and rendered as Markdown, CSV, LaTeX
(`board_text`) or HTML (`board_html`), submission metadata escaped for each format (`escape`)."""
