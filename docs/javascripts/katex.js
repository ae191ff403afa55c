// Renders the maths pymdownx.arithmatex (generic mode) leaves in the page: \( ... \) inline
// and \[ ... \] display, inside elements of class "arithmatex". KaTeX and its fonts are
// served from docs/assets/katex/ (vendored: the site needs no network when it is viewed).
// document$ is mkdocs-material's page observable: it fires on every page load, including
// the instant navigation of the theme.
document$.subscribe(function () {
  document.querySelectorAll(".arithmatex").forEach(function (element) {
    renderMathInElement(element, {
      delimiters: [
        { left: "\\(", right: "\\)", display: false },
        { left: "\\[", right: "\\]", display: true },
      ],
      throwOnError: false,
    });
  });
});
